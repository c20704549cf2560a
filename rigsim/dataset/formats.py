"""A sample in the formats computer-vision code already reads: EXR, 16-bit PNG depth, camera intrinsics
and pose as JSON, instance masks, COCO annotations and YOLO labels.

Libraries (each the one a user's loader uses): OpenEXR (the Academy Software Foundation's bindings,
``OpenEXR.File``) for float images, imageio for PNG, pycocotools for the COCO run-length encoding.

Conventions (also in the dataset's ``README.md``, :func:`dataset_card`):

* **Camera frame**: OpenCV's — x right, y down, z forward (the optical axis), origin at the
  viewpoint (:func:`viewpoint`: the entrance pupil for a dome port, a few mm off it along the axis for a flat
  one).  ``camera.json`` holds ``K`` (3 × 3, pixels), OpenCV distortion coefficients
  ``(k1, k2, p1, p2, k3)`` fitted to the housing port's projection (:func:`intrinsics`: a dome
  centred on the pupil is a pinhole, all zero; a flat port refracts: radial terms), the model's
  largest error against rigsim's projection (px), the in-water field of view (deg) and the pose: ``T_world_from_camera``
  (4 × 4, this frame to rigsim's world frame: x right, y up, z forward from the camera's start) and
  its inverse.
* **Depth**: ``range`` is the distance from the entrance pupil to the surface a pixel sees (m, along
  the ray in water); ``z`` is that point's coordinate along the optical axis (m, "z-depth", what a
  stereo rig or an RGB-D sensor reports).  Both as float32 EXR in metres (+inf where the pixel sees
  open water) and as 16-bit PNG in millimetres (0 where open water or beyond 65.535 m).
* **Instances**: one id per target (1, 2, … in scene order; 0 water), whatever its parts (a chart's
  24 patches are one instance); the seabed/bottom has its id in the mask but no COCO or YOLO
  annotation (it is "stuff", not an object); marine-snow specks are instances of the category
  ``marine-snow`` (their own mask, ``specks.png``), annotated when visible — or one crowd region per
  image, or not at all (``[dataset] snow_labels``, :data:`SNOW_LABELS`).
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np

__all__ = ["write_exr", "read_exr", "depth_maps", "depth_png_mm", "intrinsics", "viewpoint", "pose", "instances",
           "coco_annotations", "yolo_lines", "categories_for", "STUFF_KINDS", "SNOW_CATEGORY", "DEPTH_PNG_MAX_M"]

#: Target kinds that are surroundings, not objects: in the instance mask, not in COCO/YOLO.
STUFF_KINDS = ("bottom", "seabed")
#: COCO/YOLO category of marine-snow specks.
SNOW_CATEGORY = "marine-snow"
#: Largest depth a 16-bit PNG in millimetres holds (m).
DEPTH_PNG_MAX_M = 65.535


# ----------------------------------------------------------------------------------------- EXR
def write_exr(path: str | Path, channels: dict[str, np.ndarray], *, description: str = "") -> None:
    """Write float32 channels (name → (H, W) array; an (H, W, 3) array becomes ``name.R/G/B``, or
    ``R/G/B`` for the name ``""``) to ``path`` (ZIP compression), atomically."""
    import OpenEXR

    out = {}
    for name, a in channels.items():
        a = np.asarray(a, np.float32)
        if a.ndim == 3:
            for k, c in enumerate("RGB"[: a.shape[2]]):
                out[f"{name}.{c}" if name else c] = np.ascontiguousarray(a[..., k])
        else:
            out[name] = np.ascontiguousarray(a)
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    if description:
        header["comments"] = description
    path = Path(path)
    tmp = path.with_name(f".{path.name}.tmp")
    OpenEXR.File(header, out).write(str(tmp))
    os.replace(tmp, path)


def read_exr(path: str | Path) -> dict[str, np.ndarray]:
    """Channels of an EXR file (name → (H, W) float32), as OpenEXR reads them."""
    import OpenEXR

    with OpenEXR.File(str(path), separate_channels=True) as f:
        return {k: np.array(v.pixels) for k, v in f.channels().items()}


# ----------------------------------------------------------------------------------------- depth
def _pixel_rays(camera, width: int, height: int):
    from rigsim.scene.optics import WATER_INDEX, camera_rays

    X, Y = np.meshgrid((np.arange(width) + 0.5) / width, (np.arange(height) + 0.5) / height)
    return camera_rays(camera, X, Y, n_outside=WATER_INDEX)


def depth_maps(range_m: np.ndarray, camera) -> tuple[np.ndarray, np.ndarray]:
    """``(range, z)`` (m, float32, +inf where open water) from the range layer (pupil → surface, pixel
    centres): the point on each pixel's ray in water at that distance from the pupil, then its
    coordinate along the optical axis in the camera frame (from :func:`viewpoint`, the pupil for a
    dome port)."""
    r = np.asarray(range_m, float)
    h, w = r.shape
    o, d = _pixel_rays(camera, w, h)
    pupil = np.asarray(camera.position_m, float)
    _, _, fwd = camera.frame()
    rel = o - pupil
    b = np.sum(rel * d, axis=-1)
    c = np.sum(rel * rel, axis=-1) - np.where(np.isfinite(r), r, 0.0) ** 2
    t = -b + np.sqrt(np.maximum(b * b - c, 0.0))  # |o + t d − pupil| = range, the far root
    z = np.sum((o + t[..., None] * d - viewpoint(camera)) * np.asarray(fwd, float), axis=-1)
    z = np.where(np.isfinite(r), z, np.inf)
    return r.astype(np.float32), z.astype(np.float32)


def depth_png_mm(depth_m: np.ndarray) -> np.ndarray:
    """uint16 millimetres (rounded); 0 where open water (inf) or beyond :data:`DEPTH_PNG_MAX_M`."""
    d = np.asarray(depth_m, float)
    ok = np.isfinite(d) & (d >= 0) & (d <= DEPTH_PNG_MAX_M)
    return np.where(ok, np.rint(np.where(ok, d, 0.0) * 1000.0), 0).astype(np.uint16)


# ----------------------------------------------------------------------------------------- camera
def viewpoint(camera, *, grid: int = 41) -> np.ndarray:
    """The camera frame's origin (m, world): the point on the optical axis nearest, in the least-squares
    sense, to the rays the port sends into the water — the entrance pupil for a dome centred on it
    (all rays pass through it), a few millimetres off it along the axis for a flat port (its rays do
    not meet in one point: refraction at the window moves the apparent viewpoint)."""
    from rigsim.scene.optics import WATER_INDEX, camera_rays

    _, _, fwd = (np.asarray(a, float) for a in camera.frame())
    u = np.linspace(0.0, 1.0, grid)
    X, Y = np.meshgrid(u, u)
    o, d = camera_rays(camera, X, Y, n_outside=WATER_INDEX)
    o, d = o.reshape(-1, 3), d.reshape(-1, 3)
    pupil = np.asarray(camera.position_m, float)
    # distance² of pupil + s·fwd from each ray: |(I − d dᵀ)(pupil + s fwd − o)|², least squares in s
    P = np.eye(3)[None] - d[:, :, None] * d[:, None, :]
    a = np.einsum("nij,j->ni", P, fwd)
    b = np.einsum("nij,nj->ni", P, o - pupil)
    s = float(np.sum(a * b) / max(np.sum(a * a), 1e-300))
    return pupil + s * fwd


def intrinsics(camera, width: int, height: int, *, grid: int = 41, reference_m: float = 2.0) -> dict:
    """OpenCV pinhole + distortion of the in-water camera: ``K``, ``dist`` = (k1, k2, p1, p2, k3), the
    camera frame's origin (:func:`viewpoint`), the in-water fields of view (deg), and how well the model
    reproduces rigsim's own projection (:func:`rigsim.scene.optics.project_points`): the largest
    error (px) for points at ``reference_m`` and at 0.5 m from the viewpoint.

    The principal point is the image centre; the focal lengths and radial terms are fitted by linear
    least squares to the directions, seen from the viewpoint, of the points ``reference_m`` ahead
    along the rays of a ``grid`` × ``grid`` lattice of pixels (x right, y down, z forward).  A dome
    centred on the pupil is a pinhole (zero distortion, errors ~1e-9 px at every distance); a flat
    port refracts (pincushion: k1 > 0) and has no single viewpoint, so points much nearer or farther
    than ``reference_m`` are off by a little (the errors say how much).
    """
    from rigsim.scene.optics import WATER_INDEX, camera_rays, fov_water_deg, project_points

    right, up, fwd = (np.asarray(a, float) for a in camera.frame())
    C = viewpoint(camera, grid=grid)
    u = np.linspace(0.0, 1.0, grid)
    X, Y = np.meshgrid(u, u)
    o, d = camera_rays(camera, X, Y, n_outside=WATER_INDEX)

    def at_depth(z):
        t = (z - (o - C) @ fwd) / (d @ fwd)
        return o + t[..., None] * d - C

    q = at_depth(reference_m)
    xn, yn = (q @ right) / (q @ fwd), -(q @ up) / (q @ fwd)
    col, row = X * width - width / 2, Y * height - height / 2
    # pixels per unit of the sensor's x and y (an image whose aspect differs from the sensor's has
    # non-square pixels: fy / fx fixed by it)
    aspect = (height / camera.sensor_height_mm) / (width / camera.sensor_width_mm)
    r2 = xn * xn + yn * yn
    A = np.concatenate([np.stack([xn, xn * r2, xn * r2 ** 2, xn * r2 ** 3], -1).reshape(-1, 4),
                        aspect * np.stack([yn, yn * r2, yn * r2 ** 2, yn * r2 ** 3], -1).reshape(-1, 4)])
    coef, *_ = np.linalg.lstsq(A, np.concatenate([col.ravel(), row.ravel()]), rcond=None)
    fx = float(coef[0])
    k = [float(c / fx) if abs(c / fx) > 1e-12 else 0.0 for c in coef[1:]]
    fy = fx * aspect
    K = np.array([[fx, 0.0, width / 2], [0.0, fy, height / 2], [0.0, 0.0, 1.0]])
    dist = np.array([k[0], k[1], 0.0, 0.0, k[2]])

    def error_px(z):
        p = at_depth(z)
        mine = _project_opencv(p @ np.stack([right, -up, fwd], 1), K, dist)
        ref = project_points(camera, p + C, width, height, n_outside=WATER_INDEX)
        return float(np.nanmax(np.abs(mine - ref)))

    _, dv = camera_rays(camera, np.array([0.5, 0.5]), np.array([0.0, 1.0]), n_outside=WATER_INDEX)
    return {"model": "opencv", "width": int(width), "height": int(height), "K": K.tolist(),
            "dist": dist.tolist(), "port": camera.port.kind,
            "viewpoint_m": C.tolist(),
            "viewpoint_ahead_of_pupil_m": float((C - np.asarray(camera.position_m, float)) @ fwd),
            "max_error_px": {f"{reference_m:g} m": error_px(reference_m), "0.5 m": error_px(0.5)},
            "fov_water_deg": {"horizontal": fov_water_deg(camera),
                              "vertical": math.degrees(math.acos(float(np.clip(dv[0] @ dv[1], -1.0, 1.0))))}}


def _project_opencv(p_cam: np.ndarray, K: np.ndarray, dist: np.ndarray) -> np.ndarray:
    """OpenCV's projection (:func:`cv2.projectPoints`) of camera-frame points (…, 3) to pixels (…, 2)."""
    import cv2

    pts = np.ascontiguousarray(p_cam.reshape(-1, 1, 3), np.float64)
    img, _ = cv2.projectPoints(pts, np.zeros(3), np.zeros(3), K, dist)
    return img.reshape(p_cam.shape[:-1] + (2,))


def pose(camera) -> dict:
    """The camera's pose: ``T_world_from_camera`` (OpenCV camera frame, origin at :func:`viewpoint`, →
    rigsim's world frame) and its inverse, 4 × 4 row-major, metres."""
    right, up, fwd = (np.asarray(a, float) for a in camera.frame())
    T = np.eye(4)
    T[:3, 0], T[:3, 1], T[:3, 2] = right, -up, fwd  # x right, y down, z forward
    T[:3, 3] = viewpoint(camera)
    return {"T_world_from_camera": T.tolist(), "T_camera_from_world": np.linalg.inv(T).tolist(),
            "camera_frame": "OpenCV: x right, y down, z forward (optical axis), origin at the viewpoint "
                            "(the entrance pupil for a dome port)",
            "world_frame": "rigsim: x right, y up, z forward of the rig's reference, metres"}


# ----------------------------------------------------------------------------------------- labels
def categories_for(kinds, meshes, rock_meshes=()) -> list[dict]:
    """COCO categories of a dataset: its object kinds (a mesh kind by its file's stem), the meshes of a
    seabed's rocks and rubble (``rock_meshes``, by stem), then :data:`SNOW_CATEGORY`; ids from 1 in that
    order (stable for a spec)."""
    names = []
    for k in kinds:
        if k == "mesh":
            names += [Path(m).stem for m in meshes]
        elif k not in STUFF_KINDS:
            names.append(k)
    names += [Path(m).stem for m in rock_meshes]
    names.append(SNOW_CATEGORY)
    seen = list(dict.fromkeys(names))
    return [{"id": i + 1, "name": n, "supercategory": "marine-snow" if n == SNOW_CATEGORY else "object"}
            for i, n in enumerate(seen)]


def instances(object_id: np.ndarray, legend: dict[str, str], targets) -> tuple[np.ndarray, list[dict]]:
    """Instance mask (uint16: target index + 1, 0 water) and the instances ``[{id, kind, category}]``.

    ``legend``: the render's object-id legend (``"target 2 colorchecker: white"``); ``targets``: the
    scene's targets (a mesh's category is its file's stem)."""
    oid = np.asarray(object_id)
    lut = np.zeros(max([int(k) for k in legend] + [0]) + 1, np.uint16)
    for k, label in legend.items():
        lut[int(k)] = int(label.split()[1]) + 1
    inst = lut[np.clip(oid, 0, len(lut) - 1)]
    out = []
    for ti, t in enumerate(targets):
        cat = Path(t.mesh_path).stem if t.kind == "mesh" and t.mesh_path else t.kind
        out.append({"id": ti + 1, "kind": t.kind, "category": cat, "stuff": t.kind in STUFF_KINDS})
    return inst, out


#: How marine-snow specks are labelled in COCO and YOLO (``[dataset] snow_labels``): each visible speck an
#: instance; all of an image's visible specks one ``iscrowd = 1`` region (COCO's convention for many small
#: objects: evaluation ignores detections there; YOLO has no crowd, so no lines); or not at all (their
#: masks stay in specks.png either way).
SNOW_LABELS = ("instances", "crowd", "none")


def coco_annotations(inst: np.ndarray, instances_: list[dict], categories: list[dict], image_id: int,
                     specks: np.ndarray | None = None, *, first_id: int = 1, snow: str = "instances") -> list[dict]:
    """COCO annotations of one image: every visible object instance (and the visible marine-snow specks
    as ``snow`` says: :data:`SNOW_LABELS`) as RLE segmentation (pycocotools), bbox ``[x, y, w, h]`` (px,
    from the mask), area (px)."""
    from pycocotools import mask as mask_util

    cat_id = {c["name"]: c["id"] for c in categories}
    anns = []

    def add(m: np.ndarray, cat: int, extra: dict, crowd: int = 0):
        rle = mask_util.encode(np.asfortranarray(m.astype(np.uint8)))
        area = float(mask_util.area(rle))
        if area <= 0:
            return
        x, y, w, h = (float(v) for v in mask_util.toBbox(rle))
        rle["counts"] = rle["counts"].decode("ascii")
        anns.append({"id": first_id + len(anns), "image_id": int(image_id), "category_id": int(cat),
                     "segmentation": rle, "area": area, "bbox": [x, y, w, h], "iscrowd": crowd, **extra})

    for it in instances_:
        if it["stuff"] or it["category"] not in cat_id:
            continue
        add(inst == it["id"], cat_id[it["category"]], {"instance_id": it["id"]})
    if snow not in SNOW_LABELS:
        raise ValueError(f"snow labels {snow!r}: one of {', '.join(SNOW_LABELS)}")
    if specks is not None and SNOW_CATEGORY in cat_id and snow != "none":
        sp = np.asarray(specks)
        if snow == "crowd":
            add(sp > 0, cat_id[SNOW_CATEGORY], {}, crowd=1)
        else:
            for pid in np.unique(sp[sp > 0]):
                add(sp == pid, cat_id[SNOW_CATEGORY], {"particle_index": int(pid)})
    return anns


def yolo_lines(annotations: list[dict], categories: list[dict], width: int, height: int) -> str:
    """YOLO detection labels: one line ``class cx cy w h`` per annotation (class = COCO id − 1, the
    rest normalised by the image size); crowd regions have none (YOLO has no such notion)."""
    index = {c["id"]: i for i, c in enumerate(categories)}
    lines = []
    for a in annotations:
        if a.get("iscrowd"):
            continue
        x, y, w, h = a["bbox"]
        lines.append(f"{index[a['category_id']]} {(x + w / 2) / width:.6f} {(y + h / 2) / height:.6f} "
                     f"{w / width:.6f} {h / height:.6f}")
    return "\n".join(lines) + ("\n" if lines else "")


#: A PyTorch ``Dataset`` over a rigsim dataset folder that needs no rigsim import (in the dataset card
#: and the project's README; tests run it).
PYTORCH_EXAMPLE = '''\
import json, numpy as np, pandas as pd, torch, imageio.v3 as iio

class UnderwaterDataset(torch.utils.data.Dataset):
    def __init__(self, root):
        self.root, self.rows = root, pd.read_parquet(f"{root}/manifest.parquet")
    def __len__(self):
        return len(self.rows)
    def __getitem__(self, i):
        r, load = self.rows.iloc[i], lambda name: iio.imread(f"{self.root}/{name}")
        image = torch.from_numpy(load(r.image)).permute(2, 0, 1).float() / 255          # 3 x H x W sRGB
        depth = torch.from_numpy(load(r.depth_z_mm).astype(np.float32) / 1000)           # z-depth, m (0: water)
        instances = torch.from_numpy(load(r.instances).astype(np.int64))                # 0: water, k: object k
        boxes = [a["bbox"] for a in json.load(open(f"{self.root}/{r.annotations}"))["annotations"]]
        return image, depth, instances, torch.tensor(boxes).reshape(-1, 4)              # COCO x, y, w, h
'''


def _snow_text(mode: str) -> str:
    return {"instances": "`marine-snow` instances when visible",
            "crowd": "one `marine-snow` region per image with `iscrowd = 1` (no YOLO lines)",
            "none": "not annotated"}.get(mode, mode)


def dataset_card(info: dict, n_samples: int) -> str:
    """The dataset folder's ``README.md``: what is in it, the conventions, the categories, how to load it."""
    spec = info.get("spec", {})
    cats = ", ".join(f"{c['id']} {c['name']}" for c in info.get("categories", []))
    return f"""# {spec.get('name', 'rigsim dataset')}

{n_samples} samples made by rigsim (seed {info.get('seed')}, engine {spec.get('engine', 'mitsuba')},
{spec.get('width')} x {spec.get('height')} px), physically rendered underwater photographs with ground truth.

## Files

- `manifest.parquet`, `manifest.csv`: one row per sample: drawn water, rig, sensor and scene parameters,
  camera intrinsics (`fx_px`, `fy_px`, `cx_px`, `cy_px`, `k1`, `k2`, `k3`), and each file's path from here.
- `coco.json`: COCO detection/segmentation (RLE masks, boxes `[x, y, w, h]` in px) of every sample;
  categories: {cats}.
- `yolo/`: the Ultralytics layout (`data.yaml`, `images/`, `labels/` with `class cx cy w h` normalised).
- `samples/NNNNNN/`:
  `image.png` (8-bit sRGB as the camera records it), `raw.dng` (the raw mosaic), `image_linear.exr`
  (scene-linear sRGB, white = 1), `clean.png` / `clean_linear.exr` (the same shot without the water),
  `layers.exr` (`transmission.R/G/B` = exp(-c range) per camera channel; `backscatter`, `direct`,
  `forward` (and `particles`) = the noise-free linear sRGB parts of the image),
  `depth_range_m.exr` / `depth_z_m.exr` (channel `Z`, float32 m, inf = open water),
  `depth_range_mm.png` / `depth_z_mm.png` (uint16 mm, 0 = open water or beyond 65.535 m),
  `instances.png` (uint16: 0 water, k = the scene's k-th object), `mask.png` (uint16 surface ids, legend in
  `record.json`), `annotations.json` (this sample's COCO entries), `labels.txt` (YOLO), `camera.json`
  (`K`, OpenCV `dist` = k1 k2 p1 p2 k3, pose), `record.json` (every drawn and derived value).

## Conventions

- **range** = distance from the entrance pupil to the surface along the ray in water; **z** = the
  surface point's coordinate along the optical axis (what RGB-D sensors and stereo report).
- Camera frame: OpenCV (x right, y down, z forward); `T_world_from_camera` in `camera.json`.  A dome
  port is an exact pinhole; a flat port's refraction is fitted with radial distortion (`max_error_px`
  says how well).
- The seabed/bottom is in `instances.png` but not in COCO/YOLO; marine-snow specks (their masks in
  `specks.png`) are {_snow_text(spec.get('snow_labels', 'instances'))}.

## PyTorch

```python
{PYTORCH_EXAMPLE}```
"""
