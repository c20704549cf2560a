"""Writing a dataset: one folder per sample, a manifest, resumable and parallel.

Layout of ``DIR``::

    dataset.json                      the validated spec and the seed
    manifest.csv                      one row per finished sample (index, folder, drawn parameters)
    samples/000042/
        image.png                     the underwater image as the camera records it (8-bit sRGB)
        raw.dng                       its raw mosaic (LibRaw/rawpy reads it)
        image_linear.tiff             float32 scene-linear sRGB of image.png (white level = 1)
        clean.png, clean_linear.tiff  the same view, lighting and housing with the water's absorption
                                      and scattering removed; same sensor, exposure and white balance;
                                      no sensor noise
        range_m.tiff                  float32 distance from the entrance pupil to the first surface, m
                                      (inf where the ray meets no surface)
        transmission.tiff             float32 (rows, cols, 3) exp(−c_ch · range) per camera channel,
                                      c_ch = c(λ) averaged with the channel's QE (0 where range is inf)
        backscatter_linear.tiff       float32 linear sRGB of the light scattered by the water into
                                      the camera without reaching a surface (noise-free, same processing)
        mask.png                      16-bit object ids (0: water; legend in record.json)
        specks.png                    (marine snow only) 16-bit instance mask of the specks that show: the
                                      particle's 1-based index where its light in the pixel is at least 5 % of
                                      the image's median luminance (rigsim.metrics.specks; 0: none; indices
                                      above 65 535 wrap, specks.tiff holds them whole)
        specks.tiff                   (marine snow only) the same as uint32
        particle_id.tiff              (marine snow only) uint32 index of the nearest particle whose image
                                      reaches into the pixel, shown or not (every particle in view)
        particles_linear.tiff         (marine snow only) float32 linear sRGB of what the particles add to the
                                      image: their light less the light they hide (same processing)
        record.json                   every drawn parameter and derived value; written last: its
                                      presence means the sample is complete

Sample ``i`` with seed ``S`` is the same wherever and whenever it is computed.
"""

from __future__ import annotations

import csv
import io
import json
import logging
from pathlib import Path

import numpy as np

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


def _tiff(arr: np.ndarray, description: str) -> bytes:
    import tifffile

    buf = io.BytesIO()
    tifffile.imwrite(buf, np.asarray(arr, np.float32), metadata={"description": description})
    return buf.getvalue()


def _store(out: Path, index: int, res: dict) -> None:
    from rigsim.sensor.raw_io import save_dng

    d = sample_dir(out, index)
    d.mkdir(parents=True, exist_ok=True)
    atomic_write_bytes(d / "image.png", _png(res["image_srgb"]))
    tmp = d / ".raw.dng.tmp"
    save_dng(res["capture"], tmp)
    tmp.replace(d / "raw.dng")
    atomic_write_bytes(d / "image_linear.tiff", _tiff(res["image_linear"], "scene-linear sRGB, white = 1"))
    atomic_write_bytes(d / "clean.png", _png(res["clean_srgb"]))
    atomic_write_bytes(d / "clean_linear.tiff", _tiff(res["clean_linear"], "scene-linear sRGB without water"))
    atomic_write_bytes(d / "range_m.tiff", _tiff(res["range_m"], "range from the entrance pupil, m"))
    atomic_write_bytes(d / "transmission.tiff", _tiff(res["transmission"], "exp(-c_channel * range) per channel"))
    atomic_write_bytes(d / "backscatter_linear.tiff", _tiff(res["backscatter_linear"], "backscatter, linear sRGB"))
    atomic_write_bytes(d / "mask.png", _png(res["object_id"]))
    if "particle_id" in res:
        import tifffile

        buf = io.BytesIO()
        tifffile.imwrite(buf, np.asarray(res["particle_id"], np.uint32), metadata={"description": "particle ids, 1-based"})
        atomic_write_bytes(d / "particle_id.tiff", buf.getvalue())
        buf = io.BytesIO()
        tifffile.imwrite(buf, np.asarray(res["specks"], np.uint32), metadata={"description": "visible specks, 1-based"})
        atomic_write_bytes(d / "specks.tiff", buf.getvalue())
        atomic_write_bytes(d / "specks.png", _png((np.asarray(res["specks"]) & 0xFFFF).astype(np.uint16)))
        atomic_write_bytes(d / "particles_linear.tiff", _tiff(res["particles_linear"], "particles' net light, linear sRGB"))
    atomic_write_text(d / "record.json", json.dumps(res["record"], indent=1, default=float))


def _compute(args):
    from rigsim.dataset.sample import compute_sample

    return compute_sample(args)


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


def write_manifest(out: Path, n: int) -> Path:
    rows = []
    for i in range(n):
        f = sample_dir(out, i) / "record.json"
        if f.is_file():
            rows.append(_manifest_row(json.loads(f.read_text()), f"samples/{i:06d}"))
    buf = io.StringIO()
    if rows:
        w = csv.DictWriter(buf, fieldnames=list(rows[0]), lineterminator="\n")
        w.writeheader()
        w.writerows(rows)
    atomic_write_text(out / "manifest.csv", buf.getvalue())
    return out / "manifest.csv"


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
        atomic_write_text(out / "dataset.json",
                          json.dumps({"spec": spec.describe(), "seed": seed, "n": n}, indent=1))
        overrides = overrides or {}
        items = [(spec, i, seed, overrides.get(i)) for i in range(n)]
        try:
            run_tasks(items, _compute, lambda it, res: _store(out, it[1], res),
                      is_done=lambda it: (sample_dir(out, it[1]) / "record.json").is_file(),
                      key=lambda it: f"{it[1]:06d}", scheduler=scheduler, workers=workers, serial=serial,
                      progress=progress, label="dataset")
        finally:
            write_manifest(out, n)  # the finished samples, also when interrupted or some failed
    return out
