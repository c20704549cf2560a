"""Triangle meshes read from OBJ, PLY and glTF files (PyVista/VTK), once, for every consumer.

The scene (placement and scale of a mesh target, :mod:`rigsim.scene.surfaces`), the
renderer (:mod:`rigsim.render.targets` builds its ``mi.Mesh`` from these arrays) and the
configuration checks all read a mesh file through :func:`read_mesh`, so they see the
same triangles.

Reading is :func:`pyvista.read` (VTK's ``vtkOBJReader`` / ``vtkPLYReader`` / ``vtkGLTFReader``:
a glTF file's primitives, with its nodes' transforms, merged into one mesh); polygons
are split into triangles (:meth:`pyvista.PolyData.triangulate`).  Units are those of
the file, taken as metres.  A missing, unreadable or empty file is a one-line
:class:`~rigsim.errors.ConfigError` naming the file.

*Why a PLY pre-check.*  VTK's PLY reader does not check for the end of the file: a
binary PLY cut short crashes the process (segmentation fault, VTK 9.x) and an ASCII
one cut short is read with zeros in place of the missing rows, without any error.
:func:`_check_ply_length` reads the PLY header (a few text lines) and refuses a file
shorter than its header declares before VTK sees it.  OBJ files need no such check:
VTK reports a malformed or truncated OBJ.

Results are cached (:func:`functools.lru_cache`) on the resolved path and the
file's modification time, so an edited file is read again.
"""

from __future__ import annotations

import contextlib
import functools
import os
import re
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rigsim.errors import ConfigError

__all__ = ["MESH_SUFFIXES", "TriangleMesh", "read_mesh", "mesh_vertices", "placed_mesh"]

#: File types :func:`read_mesh` reads.
MESH_SUFFIXES = (".obj", ".ply", ".gltf", ".glb")
_ALLOWED = "an existing .obj, .ply, .gltf or .glb file"


@dataclass(frozen=True, eq=False)
class TriangleMesh:
    """A triangle mesh as read from a file (read-only arrays).

    Attributes
    ----------
    path
        The file (resolved).
    vertices
        (n, 3) float64 vertex positions (m, the file's coordinates).
    faces
        (m, 3) int64 vertex indices of the triangles (m may be 0: a point cloud).
    normals
        (n, 3) float64 unit vertex normals given by the file, or None.
    """

    path: Path
    vertices: np.ndarray
    faces: np.ndarray
    normals: np.ndarray | None = None

    @property
    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Axis-aligned bounding box (lower, upper corner), m."""
        return self.vertices.min(axis=0), self.vertices.max(axis=0)

    def area_m2(self) -> float:
        """Total area of the triangles (m²)."""
        a, b, c = (self.vertices[self.faces[:, k]] for k in range(3))
        return float(0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1).sum())

    def vertex_normals(self) -> np.ndarray:
        """(n, 3) unit vertex normals: the file's, else the angle-weighted mean of the face
        normals at each vertex (Thürmer & Wüthrich 1998, as Mitsuba computes them for a
        mesh file without normals); zero for a vertex on no triangle."""
        if self.normals is not None:
            return self.normals
        v, f = self.vertices, self.faces
        out = np.zeros_like(v)
        if len(f):
            p = [v[f[:, k]] for k in range(3)]
            n = np.cross(p[1] - p[0], p[2] - p[0])
            n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
            for k in range(3):
                e1, e2 = p[(k + 1) % 3] - p[k], p[(k + 2) % 3] - p[k]
                cos = np.einsum("ij,ij->i", e1, e2) / np.maximum(
                    np.linalg.norm(e1, axis=1) * np.linalg.norm(e2, axis=1), 1e-300)
                np.add.at(out, f[:, k], n * np.arccos(np.clip(cos, -1.0, 1.0))[:, None])
        length = np.linalg.norm(out, axis=1, keepdims=True)
        return np.divide(out, length, out=np.zeros_like(out), where=length > 0)


_PLY_SIZES = {"char": 1, "int8": 1, "uchar": 1, "uint8": 1, "short": 2, "int16": 2, "ushort": 2,
              "uint16": 2, "int": 4, "int32": 4, "uint": 4, "uint32": 4, "float": 4, "float32": 4,
              "double": 8, "float64": 8}
_PLY_DTYPES = {1: "u1", 2: "u2", 4: "u4"}


def _check_ply_length(p: Path) -> None:
    """Refuse a PLY file shorter than its header declares (VTK would crash or read zeros)."""
    data = p.read_bytes()
    if not data.startswith(b"ply"):
        raise ValueError("not a PLY file (no 'ply' magic line)")
    end = data.find(b"end_header")
    if end < 0:
        raise ValueError("PLY header has no end_header")
    body = data.index(b"\n", end) + 1 if b"\n" in data[end:] else len(data)
    fmt, elements = None, []   # elements: [count, [(size, None) | (count_size, item_size)]]
    for line in data[:end].decode("ascii", "replace").splitlines():
        w = line.split()
        if not w:
            continue
        try:
            if w[0] == "format":
                fmt = w[1]
            elif w[0] == "element":
                elements.append([int(w[2]), []])
            elif w[0] == "property" and elements:
                elements[-1][1].append((_PLY_SIZES[w[2]], _PLY_SIZES[w[3]]) if w[1] == "list"
                                       else (_PLY_SIZES[w[1]], None))
        except (IndexError, KeyError, ValueError):
            raise ValueError(f"bad PLY header line {line.strip()!r}") from None
    if fmt == "ascii":
        rows = sum(1 for line in data[body:].splitlines() if line.strip())
        if rows < sum(n for n, _ in elements):
            raise ValueError(f"file ends inside the data ({rows} of {sum(n for n, _ in elements)} rows)")
        return
    if fmt not in ("binary_little_endian", "binary_big_endian"):
        raise ValueError(f"unknown PLY format {fmt!r}")
    order = "<" if fmt == "binary_little_endian" else ">"
    pos = body
    for count, props in elements:
        if all(item is None for _, item in props):
            pos += count * sum(size for size, _ in props)
            continue
        if len(props) == 1 and count and pos + props[0][0] <= len(data):
            # the usual face element (one list): if every row has the first row's length, jump
            size, item = props[0]
            dt = np.dtype(order + _PLY_DTYPES.get(size, "u1"))
            stride = size + int(np.frombuffer(data, dt, 1, pos)[0]) * item
            if pos + count * stride <= len(data):
                firsts = np.frombuffer(data, np.uint8, count * stride, pos).reshape(count, stride)[:, :size]
                if np.all(firsts == firsts[0]):
                    pos += count * stride
                    continue
        for _ in range(count):  # rows with lists: walk them (list lengths are in the data)
            for size, item in props:
                if item is None:
                    pos += size
                    continue
                if pos + size > len(data):
                    raise ValueError("file ends inside the data")
                n = int(np.frombuffer(data, order + _PLY_DTYPES.get(size, "u1"), 1, pos)[0])
                pos += size + n * item
        if pos > len(data):
            break
    if pos > len(data):
        raise ValueError(f"file ends inside the data ({len(data)} of {pos} bytes)")


@contextlib.contextmanager
def _quiet_vtk():
    """VTK's own error lines (passed to Python's root logger and stderr) off while a file is read: a bad
    file is one line, the ConfigError; PyVista's warning still says the reader failed."""
    import logging

    try:
        from vtkmodules.vtkCommonCore import vtkLogger
        old = vtkLogger.GetCurrentVerbosityCutoff()
        vtkLogger.SetStderrVerbosity(vtkLogger.VERBOSITY_OFF)
    except Exception:  # noqa: BLE001 - an older VTK: its lines stay
        vtkLogger = old = None
    logging.disable(logging.CRITICAL)
    try:
        yield
    finally:
        logging.disable(logging.NOTSET)
        if vtkLogger is not None:
            vtkLogger.SetStderrVerbosity(old)


def _leaves(block):
    """The non-empty datasets of a (nested) PyVista MultiBlock."""
    import pyvista as pv

    for b in block:
        if isinstance(b, pv.MultiBlock):
            yield from _leaves(b)
        elif b is not None and b.n_points:
            yield b


@functools.lru_cache(maxsize=16)
def _read_cached(path: str, mtime: float) -> TriangleMesh:
    import pyvista as pv

    p = Path(path)
    try:
        if p.suffix.lower() == ".ply":
            _check_ply_length(p)
        with warnings.catch_warnings(record=True) as caught, _quiet_vtk():
            warnings.simplefilter("always")
            mesh = pv.read(p)
        failed = [str(w.message) for w in caught if "error" in str(w.message).lower()]
        if failed:  # PyVista's warning that the VTK reader failed (VTK's own message is logged)
            found = re.search(r"VTK reader `(\w+)`", failed[0])
            raise ValueError(f"{found.group(1) if found else 'VTK'} reported an error (malformed or "
                             "truncated file)")
    except (OSError, ValueError, RuntimeError) as exc:
        msg = " ".join(str(exc).split())[:200]
        raise ConfigError(f"cannot read mesh: {msg}", file=p, allowed="a valid OBJ, PLY or glTF file") from None
    if isinstance(mesh, pv.MultiBlock):  # glTF: one block per mesh primitive (node transforms applied by VTK)
        blocks = list(_leaves(mesh))
        if not blocks:
            raise ConfigError("mesh has no usable vertices", file=p, allowed=_ALLOWED)
        mesh = pv.merge(blocks, merge_points=False) if len(blocks) > 1 else blocks[0]
    if not isinstance(mesh, pv.PolyData):
        with warnings.catch_warnings():  # (PyVista's notice of a future default; the result is the same)
            warnings.simplefilter("ignore")
            mesh = mesh.extract_surface()
    vertices = np.asarray(mesh.points, np.float64).reshape(-1, 3)
    if vertices.shape[0] < 3 or not np.all(np.isfinite(vertices)):
        raise ConfigError("mesh has no usable vertices", file=p, allowed="an OBJ/PLY with >= 3 finite vertices")
    faces = np.zeros((0, 3), np.int64)
    if mesh.GetNumberOfPolys() > 0:
        tri = mesh.triangulate()  # same points; polygons split into triangles, winding kept
        if tri.n_points != mesh.n_points:
            raise ConfigError("cannot read mesh: triangulation changed the vertices", file=p,
                              allowed="a valid OBJ, PLY or glTF file")
        faces = np.asarray(tri.regular_faces, np.int64).reshape(-1, 3)
    if faces.size and (faces.min() < 0 or faces.max() >= len(vertices)):
        raise ConfigError("cannot read mesh: a face refers to a missing vertex", file=p,
                          allowed="a valid OBJ, PLY or glTF file")
    normals = mesh.point_data.get("Normals")
    if normals is not None:
        normals = np.asarray(normals, np.float64).reshape(-1, 3)
        length = np.linalg.norm(normals, axis=1, keepdims=True)
        normals = np.divide(normals, length, out=np.zeros_like(normals), where=length > 0)
    for a in (vertices, faces, normals):
        if a is not None:
            a.flags.writeable = False
    return TriangleMesh(path=p, vertices=vertices, faces=faces, normals=normals)


def read_mesh(path: str | Path) -> TriangleMesh:
    """Read (once) the triangle mesh of an OBJ, PLY or glTF (``.gltf``/``.glb``) file.

    Parameters
    ----------
    path
        The file (``.obj``, ``.ply`` (ASCII or binary), ``.gltf`` or ``.glb``).

    Returns
    -------
    TriangleMesh
        Vertices (m), triangles, and the file's vertex normals if it has them.

    Raises
    ------
    ConfigError
        Missing file, another suffix, unreadable or truncated file, fewer than 3 finite
        vertices (one line, naming the file).

    Examples
    --------
    >>> from rigsim.data import DATA_DIR
    >>> rock = read_mesh(DATA_DIR / "meshes" / "rock.obj")
    >>> rock.vertices.shape, rock.faces.shape
    ((162, 3), (320, 3))
    """
    p = Path(path)
    if not os.path.exists(p):
        raise ConfigError("mesh file not found", file=p, allowed=_ALLOWED)
    if not os.path.isfile(p):
        raise ConfigError("mesh path is not a file", file=p, allowed=_ALLOWED)
    if p.suffix.lower() not in MESH_SUFFIXES:
        raise ConfigError(f"unsupported mesh format {p.suffix.lower()!r}", file=p, allowed=", ".join(MESH_SUFFIXES))
    return _read_cached(str(p.resolve()), p.stat().st_mtime)


def mesh_vertices(path: str | Path) -> np.ndarray:
    """Vertex positions (n, 3) of an OBJ or PLY file (:func:`read_mesh`'s, read-only); a
    missing/unreadable file is a ConfigError."""
    return read_mesh(path).vertices


def placed_mesh(path, to_world) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A mesh file placed in the scene by the 4×4 affine ``to_world``: ``(vertices (n, 3) m, faces (m, 3),
    unit vertex normals (n, 3))`` in world coordinates — what both engines draw.  The normals are the
    file's, else the angle-weighted ones (:meth:`TriangleMesh.vertex_normals`), mapped by the inverse
    transpose of ``to_world``.  A mesh without triangles is a one-line :class:`ConfigError`."""
    mesh = read_mesh(path)
    if len(mesh.faces) == 0:
        raise ConfigError("mesh has no triangles to draw", file=mesh.path, allowed="an OBJ/PLY with faces")
    M = np.asarray(to_world, float)
    V = mesh.vertices @ M[:3, :3].T + M[:3, 3]
    N = mesh.vertex_normals() @ np.linalg.inv(M[:3, :3])   # (M⁻ᵀ n)ᵀ = nᵀ M⁻¹
    length = np.linalg.norm(N, axis=1, keepdims=True)
    N = np.divide(N, length, out=np.zeros_like(N), where=length > 0)
    return V, np.asarray(mesh.faces, np.int64), N
