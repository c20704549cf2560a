"""glTF meshes (.gltf with an embedded buffer, .glb) through the one mesh reader: the same triangles as
the OBJ of the same shape, the nodes' transforms applied, a bad file one line, both engines draw it."""

from __future__ import annotations

import base64
import json
import struct

import numpy as np
import pytest

from rigsim.errors import ConfigError
from rigsim.scene.meshes import read_mesh

V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], np.float32)
F = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]], np.uint16)


def _gltf(node: dict) -> tuple[dict, bytes]:
    buf = V.tobytes() + F.tobytes()
    doc = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0, **node}],
           "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
           "buffers": [{"byteLength": len(buf)}],
           "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": V.nbytes},
                           {"buffer": 0, "byteOffset": V.nbytes, "byteLength": F.nbytes}],
           "accessors": [{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
                          "min": [0, 0, 0], "max": [1, 1, 1]},
                         {"bufferView": 1, "componentType": 5123, "count": 12, "type": "SCALAR"}]}
    return doc, buf


def write_gltf(path, node=None):
    doc, buf = _gltf(node or {})
    doc["buffers"][0]["uri"] = "data:application/octet-stream;base64," + base64.b64encode(buf).decode()
    path.write_text(json.dumps(doc))
    return path


def write_glb(path, node=None):
    doc, buf = _gltf(node or {})
    js = json.dumps(doc).encode()
    js += b" " * (-len(js) % 4)
    buf += b"\0" * (-len(buf) % 4)
    body = struct.pack("<II", len(js), 0x4E4F534A) + js + struct.pack("<II", len(buf), 0x004E4942) + buf
    path.write_bytes(struct.pack("<III", 0x46546C67, 2, 12 + len(body)) + body)
    return path


def test_gltf_and_glb_read_as_the_obj_of_the_same_shape(tmp_path):
    obj = tmp_path / "tet.obj"
    obj.write_text("".join(f"v {x} {y} {z}\n" for x, y, z in V) + "".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in F))
    ref = read_mesh(obj)
    for f in (write_gltf(tmp_path / "tet.gltf"), write_glb(tmp_path / "tet.glb")):
        m = read_mesh(f)
        np.testing.assert_array_equal(m.vertices, ref.vertices)
        np.testing.assert_array_equal(m.faces, ref.faces)  # the winding kept
    moved = read_mesh(write_glb(tmp_path / "moved.glb", {"translation": [1.0, 0.0, 0.5], "scale": [2.0, 2.0, 2.0]}))
    np.testing.assert_allclose(moved.vertices, 2.0 * V + [1.0, 0.0, 0.5])


@pytest.mark.parametrize("content", [b"glTF\x02\x00\x00\x00", b'{"asset":'])
def test_a_bad_gltf_is_one_line(tmp_path, content, capsys):
    f = tmp_path / ("bad.glb" if content.startswith(b"glTF") else "bad.gltf")
    f.write_bytes(content)
    with pytest.raises(ConfigError, match="cannot read mesh") as e:
        read_mesh(f)
    assert "\n" not in str(e.value) and f.name in str(e.value)


def test_a_glb_subject_renders_in_both_engines(tmp_path):
    """The fast engine and the renderer see the glb's triangles where the OBJ's are (object ids)."""
    from rigsim.preview import render_preview
    from rigsim.scene.types import Rig, Scene, Target
    from tests.preview.helpers import dome_camera

    glb = write_glb(tmp_path / "tet.glb")
    scene = Scene(Rig("r", dome_camera(35.0), ()), None, (Target("mesh", 1.0, size_m=0.3, mesh_path=str(glb)),))
    si = render_preview(scene, width=32, height=32, wavelengths_nm=[550.0], layers=("object_id",))
    oid = np.asarray(si.layers["object_id"])
    assert 20 < (oid == 1).sum() < 32 * 32
    from rigsim.render import render

    mc = render(scene, width=32, height=32, spp=1, wavelengths_nm=[550.0], layers=("object_id",))
    assert np.mean(np.asarray(mc.layers["object_id"]) == oid) > 0.97
