"""Writing a dataset: one folder per sample, a manifest, resumable and parallel.

Layout of ``DIR`` (formats and conventions: :mod:`rigsim.dataset.formats`)::

    dataset.json                      the validated spec, the seed, the COCO categories
    README.md                         the dataset card: files, conventions, a PyTorch Dataset
    manifest.csv, manifest.parquet    one row per finished sample: drawn parameters, intrinsics, file paths
    coco.json                         COCO instance annotations of every sample (RLE masks, boxes)
    yolo/                             Ultralytics layout: data.yaml, images/ (links), labels/
    samples/000042/
        image.png                     the underwater image as the camera records it (8-bit sRGB)
        raw.dng                       its raw mosaic (LibRaw/rawpy reads it)
        image_linear.exr              float32 scene-linear sRGB of image.png (white level = 1)
        clean.png, clean_linear.exr   the same view, lighting and housing with the water's absorption
                                      and scattering removed; same sensor, exposure and white balance;
                                      no sensor noise
        layers.exr                    transmission.R/G/B: exp(−c_ch · range) per camera channel (c_ch = c(λ)
                                      averaged with the channel's QE; 0 where range is inf); backscatter,
                                      direct, forward (, particles).R/G/B: the noise-free linear sRGB parts of
                                      the image (light scattered back without reaching a surface; unscattered;
                                      forward-scattered on a leg; the particles' net light)
        depth_range_m.exr             float32 (channel Z) distance from the entrance pupil to the first
                                      surface along the ray, m (inf where the ray meets no surface)
        depth_z_m.exr                 float32 (channel Z) the same points' z along the optical axis, m
        depth_range_mm.png, depth_z_mm.png   uint16 millimetres (0: no surface or beyond 65.535 m)
        mask.png                      16-bit surface ids (0: water; legend in record.json)
        instances.png                 16-bit object instances (0: water; k: the scene's k-th target)
        annotations.json              this sample's COCO image entry and annotations
        labels.txt                    YOLO labels (class cx cy w h, normalised)
        camera.json                   K, OpenCV distortion of the port, in-water field of view, pose
        specks.png                    (marine snow only) 16-bit instance mask of the specks that show: the
                                      particle's 1-based index where its light in the pixel is at least 5 % of
                                      the image's median luminance (rigsim.metrics.specks; 0: none; indices
                                      above 65 535 wrap, specks.tiff holds them whole)
        specks.tiff                   (marine snow only) the same as uint32
        particle_id.tiff              (marine snow only) uint32 index of the nearest particle whose image
                                      reaches into the pixel, shown or not (every particle in view)
        record.json                   every drawn parameter and derived value, and the code that computed
                                      them (``code``, :func:`rigsim.code_version.code_version`); written
                                      last: its presence means the sample is complete

Sample ``i`` with seed ``S`` is the same wherever and whenever the same code computes it.  A run resumed
after rigsim changed computes the samples of other code again (a dataset is one engine's images).
"""

from __future__ import annotations

import csv
import io
import json
import logging
from pathlib import Path

import numpy as np

from rigsim.code_version import code_version, computed_here
from rigsim.dataset.spec import DatasetSpec
from rigsim.fileio import (atomic_write_bytes, atomic_write_text, drop_unreadable_records, folder_lock,
                           remove_stale_temp_files)

log = logging.getLogger(__name__)

__all__ = ["run_dataset", "sample_dir", "MAX_SAMPLES"]

#: Most samples one dataset run may ask for.
MAX_SAMPLES = 1_000_000


def sample_dir(out: Path, index: int) -> Path:
    return Path(out) / "samples" / f"{index:06d}"


def _png(arr: np.ndarray) -> bytes:
    import imageio.v3 as iio

    buf = io.BytesIO()
    iio.imwrite(buf, arr, extension=".png")
    return buf.getvalue()


def _store(out: Path, index: int, res: dict) -> None:
    from rigsim.dataset.formats import depth_png_mm, write_exr, yolo_lines
    from rigsim.sensor.raw_io import save_dng

    d = sample_dir(out, index)
    d.mkdir(parents=True, exist_ok=True)
    h, w = np.shape(res["range_m"])
    atomic_write_bytes(d / "image.png", _png(res["image_srgb"]))
    tmp = d / ".raw.dng.tmp"
    save_dng(res["capture"], tmp)
    tmp.replace(d / "raw.dng")
    write_exr(d / "image_linear.exr", {"": res["image_linear"]}, description="scene-linear sRGB of image.png, white = 1")
    atomic_write_bytes(d / "clean.png", _png(res["clean_srgb"]))
    write_exr(d / "clean_linear.exr", {"": res["clean_linear"]}, description="scene-linear sRGB without the water")
    layers = {"transmission": res["transmission"], "backscatter": res["backscatter_linear"],
              "direct": res["direct_linear"], "forward": res["forward_linear"]}
    if "particles_linear" in res:
        layers["particles"] = res["particles_linear"]
    write_exr(d / "layers.exr", layers,
              description="transmission: exp(-c_channel range) per camera channel; backscatter, direct, forward"
                          "(, particles): noise-free linear sRGB parts of image_linear.exr")
    write_exr(d / "depth_range_m.exr", {"Z": res["range_m"]}, description="range: entrance pupil to surface, m; inf: water")
    write_exr(d / "depth_z_m.exr", {"Z": res["z_m"]}, description="z-depth along the optical axis, m; inf: water")
    atomic_write_bytes(d / "depth_range_mm.png", _png(depth_png_mm(res["range_m"])))
    atomic_write_bytes(d / "depth_z_mm.png", _png(depth_png_mm(res["z_m"])))
    atomic_write_bytes(d / "mask.png", _png(res["object_id"]))
    atomic_write_bytes(d / "instances.png", _png(np.asarray(res["instances"], np.uint16)))
    atomic_write_text(d / "camera.json", json.dumps(res["camera"], indent=1))
    folder = f"samples/{index:06d}"
    atomic_write_text(d / "annotations.json", json.dumps(
        {"image": {"id": int(index), "file_name": f"{folder}/image.png", "width": int(w), "height": int(h)},
         "annotations": res["annotations"]}, indent=None))
    atomic_write_text(d / "labels.txt", yolo_lines(res["annotations"], res["categories"], w, h))
    if "particle_id" in res:
        import tifffile

        buf = io.BytesIO()
        tifffile.imwrite(buf, np.asarray(res["particle_id"], np.uint32), metadata={"description": "particle ids, 1-based"})
        atomic_write_bytes(d / "particle_id.tiff", buf.getvalue())
        buf = io.BytesIO()
        tifffile.imwrite(buf, np.asarray(res["specks"], np.uint32), metadata={"description": "visible specks, 1-based"})
        atomic_write_bytes(d / "specks.tiff", buf.getvalue())
        atomic_write_bytes(d / "specks.png", _png((np.asarray(res["specks"]) & 0xFFFF).astype(np.uint16)))
    atomic_write_text(d / "record.json", json.dumps(res["record"], indent=1, default=float))


def _compute(args):
    from rigsim.dataset.sample import compute_sample

    res = compute_sample(args)
    res["record"]["code"] = code_version()  # the code that computed it (a resumed run of other code redoes it)
    return res


def _store_checked(out: Path, index: int, res: dict) -> None:
    """:func:`_store`, saying so where a worker computed the sample with other code than this run's."""
    _store(out, index, res)
    if res["record"].get("code") != code_version():
        log.warning("sample %06d was computed by other rigsim code (%s, this run %s): rigsim's files changed while "
                    "the dataset ran; it is left out of the manifest - run the dataset again to compute it with one "
                    "code", index, res["record"].get("code"), code_version())


def _finished(out: Path, index: int) -> bool:
    """Sample ``index`` has a record of this code (:func:`rigsim.code_version.computed_here`)."""
    try:
        rec = json.loads((sample_dir(out, index) / "record.json").read_text())
    except (OSError, ValueError):
        return False
    return isinstance(rec, dict) and computed_here(rec)


def _manifest_row(rec: dict, folder: str) -> dict:
    w = rec["water"]
    return {"index": rec["index"], "folder": folder, "seed": rec["seed"],
            "water": w.get("preset", "constituents"), "chl_mg_per_m3": w.get("chl_mg_per_m3"),
            "cdom_a440_per_m": w.get("cdom_a440_per_m"), "small_particles_ppm": w.get("small_particles_ppm"),
            "large_particles_ppm": w.get("large_particles_ppm"), "c_550_per_m": rec.get("c_550_per_m"),
            "rig": Path(rec["rig"]).stem, "power_fraction": rec["power_fraction"], "sensor": rec["sensor"],
            "n_objects": len(rec["objects"]), "object_kinds": "|".join(o["kind"] for o in rec["objects"]),
            "distance_m": min(o["distance_m"] for o in rec["objects"]),
            "bottom_altitude_m": rec.get("bottom_altitude_m"),
            "exposure_time_s": rec["exposure"]["exposure_time_s"], "iso": rec["exposure"]["iso"],
            "flash_scale": rec["exposure"].get("flash_scale"),
            "particles_level": (rec.get("particles") or {}).get("level"),
            "particles_count": (rec.get("particles") or {}).get("count")}


def _camera_columns(d: Path) -> dict:
    f = d / "camera.json"
    if not f.is_file():
        return {}
    cam = json.loads(f.read_text())
    K, dist = cam["K"], cam["dist"]
    return {"fx_px": K[0][0], "fy_px": K[1][1], "cx_px": K[0][2], "cy_px": K[1][2], "k1": dist[0], "k2": dist[1],
            "k3": dist[4], "fov_water_h_deg": cam["fov_water_deg"]["horizontal"], "port": cam["port"]}


#: Files of a sample listed in the manifest (column → file in the sample's folder).
MANIFEST_FILES = {"image": "image.png", "image_linear": "image_linear.exr", "raw": "raw.dng", "clean": "clean.png",
                  "depth_range_m": "depth_range_m.exr", "depth_z_m": "depth_z_m.exr",
                  "depth_range_mm": "depth_range_mm.png", "depth_z_mm": "depth_z_mm.png",
                  "instances": "instances.png", "mask": "mask.png", "layers": "layers.exr",
                  "camera": "camera.json", "annotations": "annotations.json", "yolo_labels": "labels.txt",
                  "record": "record.json"}


def write_manifest(out: Path, n: int) -> Path:
    """The dataset-level files from the finished samples: ``manifest.csv`` and ``manifest.parquet`` (one
    row per sample: drawn parameters, camera intrinsics, file paths relative to ``out``), ``coco.json``
    (every sample's annotations, ids renumbered), ``yolo/`` (Ultralytics layout: ``data.yaml``,
    ``images/`` as links to the samples' images, ``labels/``) and ``README.md`` (the dataset card)."""
    import pandas as pd

    from rigsim.dataset.formats import dataset_card

    out = Path(out)
    rows, images, anns, categories = [], [], [], None
    for i in range(n):
        d = sample_dir(out, i)
        f = d / "record.json"
        if not _finished(out, i):
            continue  # not finished, or by other code (an interrupted run after an update: not mixed in)
        folder = f"samples/{i:06d}"
        row = _manifest_row(json.loads(f.read_text()), folder)
        row.update(_camera_columns(d))
        row.update({k: f"{folder}/{v}" for k, v in MANIFEST_FILES.items() if (d / v).is_file()})
        rows.append(row)
        a = d / "annotations.json"
        if a.is_file():
            got = json.loads(a.read_text())
            images.append(got["image"])
            for ann in got["annotations"]:
                anns.append({**ann, "id": len(anns) + 1})
    buf = io.StringIO()
    if rows:
        w = csv.DictWriter(buf, fieldnames=list(dict.fromkeys(k for r in rows for k in r)), lineterminator="\n")
        w.writeheader()
        w.writerows(rows)
    atomic_write_text(out / "manifest.csv", buf.getvalue())
    pq = io.BytesIO()
    pd.DataFrame(rows).to_parquet(pq, index=False)
    atomic_write_bytes(out / "manifest.parquet", pq.getvalue())
    spec = json.loads((out / "dataset.json").read_text()) if (out / "dataset.json").is_file() else {}
    categories = spec.get("categories", [])
    atomic_write_text(out / "coco.json", json.dumps(
        {"info": {"description": f"rigsim dataset {spec.get('spec', {}).get('name', '')}".strip(),
                  "version": "1.0", "contributor": "rigsim"},
         "images": images, "annotations": anns, "categories": categories}))
    _write_yolo(out, rows, categories)
    atomic_write_text(out / "README.md", dataset_card(spec, len(rows)))
    return out / "manifest.csv"


def _write_yolo(out: Path, rows: list[dict], categories: list[dict]) -> None:
    """Ultralytics' layout: ``yolo/images/NNNNNN.png`` (relative links to the samples' images),
    ``yolo/labels/NNNNNN.txt``, ``yolo/data.yaml``."""
    import os

    y = out / "yolo"
    (y / "images").mkdir(parents=True, exist_ok=True)
    (y / "labels").mkdir(parents=True, exist_ok=True)
    for r in rows:
        if "image" not in r or "yolo_labels" not in r:
            continue
        name = Path(r["folder"]).name
        link = y / "images" / f"{name}.png"
        if not link.is_symlink() and not link.exists():
            os.symlink(os.path.relpath(out / r["image"], link.parent), link)
        atomic_write_text(y / "labels" / f"{name}.txt", (out / r["yolo_labels"]).read_text())
    names = "\n".join(f"  {i}: {c['name']}" for i, c in enumerate(categories))
    atomic_write_text(y / "data.yaml", f"path: .\ntrain: images\nval: images\nnames:\n{names}\n")


def run_dataset(spec: DatasetSpec, n: int, out: str | Path, *, seed: int = 0, scheduler: str | None = None,
                workers: int | None = None, serial: bool = False, progress: bool = True,
                overrides: dict[int, dict] | None = None) -> Path:
    """Generate samples ``0 … n−1`` into ``out`` (finished ones are skipped) and write the manifest.

    ``overrides`` replaces drawn parameters of given samples (tests: e.g. ``{0: {"water": {"vacuum": True}}}``).
    """
    from rigsim.parallel import run_tasks

    from rigsim.errors import ConfigError

    if isinstance(n, bool) or not isinstance(n, int) or not 1 <= n <= MAX_SAMPLES:
        raise ConfigError(f"need 1 … {MAX_SAMPLES} samples, got {n}", field="--n", allowed=f"1 … {MAX_SAMPLES}")
    if isinstance(seed, bool) or not isinstance(seed, int) or not 0 <= seed < 2**63:
        raise ConfigError(f"the dataset seed must be a whole number >= 0, got {seed}", field="--seed",
                          allowed=f"0 … {2**63 - 1}")
    out = Path(out)
    with folder_lock(out):  # one run per dataset folder; released however this process ends
        remove_stale_temp_files(out)  # what a killed run was writing
        for f in drop_unreadable_records(out, "samples/*/record.json", ("index", "water", "objects")):
            log.warning("%s was damaged: computing that sample again", f)
        other = [i for i in range(n) if (sample_dir(out, i) / "record.json").is_file() and not _finished(out, i)]
        if other:
            log.warning("%d finished sample(s) in %s were computed by other rigsim code (not %s): computing them "
                        "again", len(other), out, code_version())
        from rigsim.dataset.sample import spec_categories

        atomic_write_text(out / "dataset.json",
                          json.dumps({"spec": spec.describe(), "seed": seed, "n": n,
                                      "categories": spec_categories(spec)}, indent=1))
        overrides = overrides or {}
        items = [(spec, i, seed, overrides.get(i)) for i in range(n)]
        try:
            run_tasks(items, _compute, lambda it, res: _store_checked(out, it[1], res),
                      is_done=lambda it: _finished(out, it[1]),
                      key=lambda it: f"{it[1]:06d}", scheduler=scheduler, workers=workers, serial=serial,
                      progress=progress, label="dataset")
        finally:
            write_manifest(out, n)  # the finished samples, also when interrupted or some failed
    return out
