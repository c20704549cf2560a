"""The one mesh reader (rigsim.scene.meshes): OBJ and PLY (ASCII, binary) round trips, bad files."""

from __future__ import annotations

import os

import numpy as np
import pytest

from rigsim.data import DATA_DIR
from rigsim.errors import ConfigError
from rigsim.scene.meshes import read_mesh
from rigsim.scene.meshes import mesh_vertices

pv = pytest.importorskip("pyvista")

# a square pyramid: 5 vertices, a quad base and 4 triangles (6 triangles after splitting)
V = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0.5, 0.5, 0.8]], float)
FACES = [[0, 3, 2, 1], [0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]]
AREA = 1.0 + 4 * 0.5 * np.hypot(0.8, 0.5)


def _write_obj(path, faces=FACES, extra=""):
    lines = [f"v {x:.17g} {y:.17g} {z:.17g}" for x, y, z in V] + ["f " + " ".join(str(i + 1) for i in f)
                                                                  for f in faces]
    path.write_text("# pyramid\n" + "\n".join(lines) + "\n" + extra)
    return path


def _ply_header(fmt, n_vert, n_face, normals=False):
    props = "property float x\nproperty float y\nproperty float z\n"
    if normals:
        props += "property float nx\nproperty float ny\nproperty float nz\n"
    return (f"ply\nformat {fmt} 1.0\nelement vertex {n_vert}\n{props}element face {n_face}\n"
            "property list uchar int vertex_indices\nend_header\n")


def _write_ply_binary(path, faces=FACES, normals=None):
    body = np.hstack([V, normals]).astype("<f4").tobytes() if normals is not None else V.astype("<f4").tobytes()
    for f in faces:
        body += bytes([len(f)]) + np.asarray(f, "<i4").tobytes()
    path.write_bytes(_ply_header("binary_little_endian", len(V), len(faces), normals is not None).encode() + body)
    return path


def _write_ply_ascii(path, faces=FACES):
    rows = [" ".join(f"{c:.9g}" for c in v) for v in V] + [" ".join(map(str, [len(f), *f])) for f in faces]
    path.write_text(_ply_header("ascii", len(V), len(faces)) + "\n".join(rows) + "\n")
    return path


def _check_pyramid(m, rtol=1e-7):
    assert m.vertices.dtype == np.float64 and m.vertices.shape == (5, 3)
    assert m.vertices == pytest.approx(V, rel=rtol, abs=1e-7)
    assert m.faces.shape == (6, 3) and m.faces.dtype == np.int64
    assert m.area_m2() == pytest.approx(AREA, rel=1e-6)
    lo, hi = m.bounds
    assert lo == pytest.approx([0, 0, 0]) and hi == pytest.approx([1, 1, 0.8], rel=1e-7)
    # winding kept: every side triangle faces away from the apex's foot, the base faces down
    a, b, c = (m.vertices[m.faces[:, k]] for k in range(3))
    n = np.cross(b - a, c - a)
    centroid = (a + b + c) / 3 - V.mean(axis=0)
    assert np.all(np.einsum("ij,ij->i", n, centroid) > 0)
    assert not m.vertices.flags.writeable and not m.faces.flags.writeable


@pytest.mark.parametrize("writer", [_write_obj, _write_ply_ascii, _write_ply_binary])
def test_round_trip_obj_and_ply(tmp_path, writer):
    name = "mesh.obj" if writer is _write_obj else "mesh.ply"
    m = read_mesh(writer(tmp_path / name))
    _check_pyramid(m, rtol=1e-7 if writer is _write_obj else 1e-6)
    assert np.array_equal(mesh_vertices(tmp_path / name), m.vertices)


def test_pyvista_written_ply(tmp_path):
    rock = read_mesh(DATA_DIR / "meshes" / "rock.obj")
    assert rock.vertices.shape == (162, 3) and rock.faces.shape == (320, 3) and rock.normals is None
    poly = pv.PolyData(np.asarray(rock.vertices), np.hstack([np.full((320, 1), 3), rock.faces]).ravel())
    for binary in (True, False):
        path = tmp_path / f"rock_{binary}.ply"
        poly.save(path, binary=binary)
        m = read_mesh(path)
        assert m.vertices == pytest.approx(rock.vertices, abs=1e-6)
        assert np.array_equal(m.faces, rock.faces)
        assert m.area_m2() == pytest.approx(rock.area_m2(), rel=1e-6)


def test_file_normals_are_kept_and_unit(tmp_path):
    given = np.tile([0.0, 0.0, 2.0], (len(V), 1))      # not unit in the file
    m = read_mesh(_write_ply_binary(tmp_path / "n.ply", normals=given))
    assert m.normals == pytest.approx(np.tile([0.0, 0.0, 1.0], (len(V), 1)))
    assert m.vertex_normals() is m.normals
    assert read_mesh(_write_ply_binary(tmp_path / "no_n.ply")).normals is None


def test_smooth_normals_point_outwards():
    rock = read_mesh(DATA_DIR / "meshes" / "rock.obj")
    n = rock.vertex_normals()
    assert np.linalg.norm(n, axis=1) == pytest.approx(np.ones(162))
    assert np.all(np.einsum("ij,ij->i", n, rock.vertices - rock.vertices.mean(axis=0)) > 0)


def _one_line_error(path, match):
    with pytest.raises(ConfigError, match=match) as e:
        read_mesh(path)
    assert path.name in str(e.value) and "\n" not in str(e.value)


def test_truncated_files(tmp_path):
    full = _write_ply_binary(tmp_path / "full.ply").read_bytes()
    header = len(_ply_header("binary_little_endian", 5, 6))
    for cut in (header + 20, header + 60 + 7, len(full) - 1):   # in the vertices, in the faces, last byte
        p = tmp_path / f"cut{cut}.ply"
        p.write_bytes(full[:cut])
        _one_line_error(p, "cannot read mesh: file ends inside the data")
    asc = _write_ply_ascii(tmp_path / "a.ply").read_text().splitlines()
    (tmp_path / "cut_ascii.ply").write_text("\n".join(asc[:-3]) + "\n")
    _one_line_error(tmp_path / "cut_ascii.ply", "file ends inside the data")
    obj = _write_obj(tmp_path / "full.obj").read_text()
    (tmp_path / "cut.obj").write_text(obj[:obj.index("v 1 1 0") + 4])      # ends inside a vertex line
    _one_line_error(tmp_path / "cut.obj", "cannot read mesh")


def test_garbage_empty_and_missing(tmp_path):
    rng = np.random.default_rng(0)
    for name in ("noise.obj", "noise.ply"):
        (tmp_path / name).write_bytes(rng.integers(0, 256, 4096, dtype=np.uint8).tobytes())
    _one_line_error(tmp_path / "noise.obj", "no usable vertices")
    _one_line_error(tmp_path / "noise.ply", "cannot read mesh: not a PLY file")
    (tmp_path / "empty.obj").write_text("# nothing\n")
    _one_line_error(tmp_path / "empty.obj", "no usable vertices")
    (tmp_path / "empty.ply").write_text(_ply_header("ascii", 0, 0))
    _one_line_error(tmp_path / "empty.ply", "no usable vertices")
    (tmp_path / "badface.ply").write_text(_ply_header("ascii", 5, 1) + "\n".join(
        " ".join(map(str, v)) for v in V) + "\n3 0 1 9\n")
    _one_line_error(tmp_path / "badface.ply", "cannot read mesh")
    _one_line_error(tmp_path / "fish.obj", "mesh file not found")
    (tmp_path / "fish.stl").write_text("solid x\n")
    _one_line_error(tmp_path / "fish.stl", "unsupported mesh format '.stl'")
    (tmp_path / "dir.obj").mkdir()
    _one_line_error(tmp_path / "dir.obj", "not a file")


def test_cached_until_the_file_changes(tmp_path):
    p = _write_obj(tmp_path / "m.obj")
    a = read_mesh(p)
    assert read_mesh(p) is a and read_mesh(str(p)) is a
    _write_obj(p, faces=FACES[1:])                                 # the base removed
    st = p.stat()
    os.utime(p, ns=(st.st_atime_ns, st.st_mtime_ns + 1_000_000_000))
    b = read_mesh(p)
    assert b is not a and b.faces.shape == (4, 3)
