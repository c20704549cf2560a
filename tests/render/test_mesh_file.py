"""Mesh files reach Mitsuba as the arrays of rigsim.scene.meshes (one reader for scene and renderer)."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("mitsuba")

from rigsim.data import DATA_DIR
from rigsim.errors import ConfigError
from rigsim.render.mitsuba_scene import build_mitsuba_scene
from rigsim.render.targets import MESH_TYPE, file_mesh
from rigsim.render.variant import mitsuba
from rigsim.scene.build import build_scene
from rigsim.scene.meshes import read_mesh
from rigsim.scene.surfaces import target_surfaces
from rigsim.scene.types import Camera, Rig

mi, dr = mitsuba()
ROCK = DATA_DIR / "meshes" / "rock.obj"


def _placed(path, distance=2.0):
    sc = build_scene(Rig(name="r", camera=Camera()), None, str(path), distance)
    (s,) = target_surfaces(sc.targets[0], sc.camera)
    return sc, s.matrix()


def test_mitsuba_mesh_is_the_readers_mesh_placed():
    sc, M = _placed(ROCK)
    mesh = read_mesh(ROCK)
    V = mesh.vertices @ M[:3, :3].T + M[:3, 3]
    scale = np.linalg.norm(M[:3, 0])
    ms = build_mitsuba_scene(sc, lights=())
    (shape,) = [sh for sh in ms.scene.shapes() if sh.id() in ms.shape_ids]
    params = mi.traverse(shape)
    Vm = np.array(params["vertex_positions"]).reshape(-1, 3)
    Fm = np.array(params["faces"]).reshape(-1, 3)
    assert np.array_equal(Fm, mesh.faces)                              # the same triangles
    assert Vm == pytest.approx(V, abs=1e-6)
    bbox = shape.bbox()
    assert np.array([list(bbox.min), list(bbox.max)]) == pytest.approx(np.array([V.min(0), V.max(0)]), abs=1e-6)
    area = float(np.asarray(shape.surface_area()).ravel()[0])
    assert area == pytest.approx(mesh.area_m2() * scale ** 2, rel=1e-5)
    # smooth shading normals, as Mitsuba's own OBJ loader computed them: unit, outwards
    assert shape.has_vertex_normals()
    N = np.array(params["vertex_normals"]).reshape(-1, 3)
    assert np.linalg.norm(N, axis=1) == pytest.approx(np.ones(len(N)), abs=1e-6)
    assert np.all(np.einsum("ij,ij->i", N, Vm - Vm.mean(axis=0)) > 0)


def test_file_mesh_spec_and_point_clouds(tmp_path):
    _, M = _placed(ROCK)
    spec = file_mesh(ROCK, M)
    assert spec["type"] == MESH_TYPE and spec["faces"].dtype == np.uint32
    assert spec["vertex_positions"].shape == spec["vertex_normals"].shape == (162, 3)
    cloud = tmp_path / "cloud.obj"
    cloud.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\n")
    with pytest.raises(ConfigError, match="no triangles") as e:
        file_mesh(cloud, np.eye(4))
    assert "cloud.obj" in str(e.value)
