"""The fast engine's check images of published agreement rows, as one checkout makes them (for
``bench_fast_engine_agreement.py --verify-unchanged``, which runs this script once with the checkout of a row's
engine and once with this one, and compares what they save bit for bit).

    PYTHONPATH=<checkout> python benchmarks/fast_snapshot.py <checkout> <rows.json> <out_dir> [--first-case]

``rows.json``: a list of published rows (``lighting``, ``water``, ``rig``, ``distances_m``, ``settings``:
``data/fast_engine/agreement.csv``).  For row ``i`` it writes ``<out_dir>/<i>.npz``: for every case of the row's
study — the study that checkout's benchmark makes (its own ``STUDY`` template, read from its copy of
``bench_fast_engine_agreement.py``; its rigs) — the radiance and every layer of the fast image at the check's size
and of each photon batch's image (``<target>@<distance>/...``), or ``<i>.error`` with the reason.

Only the package of the checkout is imported (``rigsim`` from ``PYTHONPATH``; this file puts nothing on
``sys.path``), through the calls every checkout since 2026-12-05 has: :func:`rigsim.study.case.fast_check_images`
where it exists, else what the check called before it (``render_preview`` with ``traced_out``, then
``render_photon_batches``), without the further seeds of the noise estimate (they change the SE, not the image).
``--first-case``: each row's first case alone (a changed engine shows in it; the rows it leaves identical are then
snapshot whole).
"""

from __future__ import annotations

import ast
import json
import re
import sys
import tempfile
import traceback
from pathlib import Path

import numpy as np


def _template(checkout: Path) -> str:
    """The checkout's benchmark's ``STUDY`` template (a string constant, read without importing the file)."""
    src = (checkout / "benchmarks" / "bench_fast_engine_agreement.py").read_text()
    for node in ast.parse(src).body:
        if isinstance(node, ast.Assign) and getattr(node.targets[0], "id", "") == "STUDY":
            return ast.literal_eval(node.value)
    raise ValueError(f"{checkout}: no STUDY template in its bench_fast_engine_agreement.py")


def _study_text(checkout: Path, row: dict) -> str:
    """The study the checkout's benchmark makes for a published row (its fast side: size, multiple scattering,
    rig, water, distances, daylight depth; the Monte Carlo settings do not change the fast images)."""
    light, settings = row["lighting"], row.get("settings", "")
    size = re.search(r"(\d+)x(\d+) px", settings)
    ms = re.search(r"multiple scattering (\w+)", settings)
    if size is None or ms is None:
        raise ValueError(f"settings without the image size or the multiple scattering: {settings!r}")
    depth = light.removeprefix("daylight-").removesuffix("m") if light.startswith("daylight-") else None
    rig = checkout / "rigs" / f"{'ambient-only' if depth else row['rig']}.toml"
    distances = sorted(float(x) for x in row["distances_m"].split(","))
    return _template(checkout).format(
        name=light, rigs=[str(rig)], waters=[row["water"]], distances=distances,
        depth=f"depth_m = {float(depth)}" if depth else "", width=int(size[1]), height=int(size[2]), spp=32,
        seeds=4, max_seeds=4, target_se=0.015, ms=ms[1], reference="monte-carlo", hybrid_photons=1_000_000,
        hybrid_spp=64, hybrid_veil=16, hybrid_sigma=4.0, fast_noise=0, hybrid_order="", hybrid_max="",
        hybrid_veil_max="").replace("'", '"')


def fast_images(spec, case) -> tuple:
    """The fast side of a case's check, as the checkout makes it: (image, photon batches' images)."""
    try:
        from rigsim.study.case import fast_check_images
    except ImportError:  # before 2026-12-07: the first two steps of compute_check
        from rigsim.preview import render_photon_batches, render_preview
        from rigsim.study.case import case_scene, study_layers

        scene, water, _ = case_scene(spec, case)
        ck, wl = spec.check, spec.render.wavelengths_nm
        layers = study_layers(water)
        traced: dict = {}
        fast = render_preview(scene, width=ck.width, height=ck.height, wavelengths_nm=wl, layers=layers,
                              multiple=spec.render.preview_multiple, seed=spec.case_seed(case), traced_out=traced)
        return fast, render_photon_batches(scene, traced, traced_size=(ck.width, ck.height), width=ck.width,
                                           height=ck.height, wavelengths_nm=wl, layers=layers)
    fast, batches, _ = fast_check_images(spec, case)
    return fast, batches


def snapshot(checkout: Path, rows: list[dict], out_dir: Path, *, first_case: bool = False) -> None:
    """Write each row's arrays (module docstring) to ``out_dir`` (``first_case``: of its first case alone)."""
    import rigsim
    from rigsim.study import load_study

    if not Path(rigsim.__file__).resolve().is_relative_to(checkout.resolve()):  # (else both sides would be one code)
        raise SystemExit(f"rigsim was imported from {rigsim.__file__}, not from {checkout}: set PYTHONPATH={checkout}")

    out_dir.mkdir(parents=True, exist_ok=True)
    for i, row in enumerate(rows):
        try:
            with tempfile.TemporaryDirectory() as d:
                p = Path(d) / "study.toml"
                p.write_text(_study_text(checkout, row))
                spec = load_study(p)
            arrays = {}
            cases = spec.check_cases()
            for case in cases[:1] if first_case else cases:
                fast, batches = fast_images(spec, case)
                key = f"{case.target}@{case.distance_m:g}"
                for j, im in enumerate([fast] + list(batches)):
                    at = key if j == 0 else f"{key}/batch{j - 1}"
                    arrays[f"{at}/radiance"] = np.asarray(im.radiance)
                    for name, a in im.layers.items():
                        arrays[f"{at}/{name}"] = np.asarray(a)
            np.savez_compressed(out_dir / f"{i}.npz", **arrays)
        except Exception:  # noqa: BLE001 - recorded for the caller, which then leaves the row as it is
            (out_dir / f"{i}.error").write_text(traceback.format_exc())
        print(f"{checkout.name}: row {i + 1} of {len(rows)}", flush=True)


def same_arrays(a_file: Path, b_file: Path) -> tuple[bool, str]:
    """Whether two snapshots hold the same arrays bit for bit (NaN equal to NaN), and what differs if not."""
    with np.load(a_file) as a, np.load(b_file) as b:
        ka, kb = set(a.files), set(b.files)
        if ka != kb:
            return False, f"different arrays ({sorted(ka ^ kb)[:3]})"
        if not ka:
            return False, "no arrays"
        for k in sorted(ka):
            x, y = a[k], b[k]
            if x.shape != y.shape or x.dtype != y.dtype or not np.array_equal(x, y, equal_nan=True):
                with np.errstate(invalid="ignore"):
                    d = np.abs(x.astype(float) - y.astype(float)) if x.shape == y.shape else np.array([np.inf])
                    rel = float(np.nanmax(d) / max(float(np.nanmax(np.abs(x.astype(float)))), 1e-300))
                return False, f"{k} differs (largest difference {rel:.2g} of the largest value)"
        return True, f"{len(ka)} arrays identical"


if __name__ == "__main__":
    args = sys.argv[1:]
    first = args[3:] == ["--first-case"]
    if len(args) != 3 and not first:
        print("usage: " + next(ln.strip() for ln in __doc__.splitlines() if "PYTHONPATH=" in ln), file=sys.stderr)
        sys.exit(2)
    snapshot(Path(args[0]).resolve(), json.loads(Path(args[1]).read_text()), Path(args[2]), first_case=first)
