"""The optimum versus subject distance and water: a table a diver can print.

:func:`sweep_optimum` runs :func:`~rigsim.optimise.search.optimise` for every water × distance and
keeps each result as ``cell-<water>-<distance>m.json`` in the output folder the moment it is found
(atomically), so an interrupted sweep resumes where it stopped (a cell found with other settings, or by other
rigsim code — each names the code that computed it, :mod:`rigsim.code_version` — is searched again, as a study's
cases are); :func:`write_sweep` writes
``sweep.csv``, ``sweep.png`` (arm length, outward turn and score gain versus distance, one line per
water), an optimised rig file per cell and ``sweep.html`` with one sentence per water:
"For 1–2 m in coastal water the arms should be 0.41–0.80 m long, turned 52–57° outward (arms 9–25° above the
horizontal, 18–22 cm behind the lens, 110° beams)".
"""

from __future__ import annotations

import io
import json
import logging
import math
import re
from dataclasses import asdict, replace
from pathlib import Path

from rigsim.config.rigdoc import RigDoc
from rigsim.optimise.objective import DEFAULT_WEIGHTS, Setting, Weights
from rigsim.optimise.search import optimise

__all__ = ["sweep_optimum", "write_sweep", "water_sentence", "cell_name"]

log = logging.getLogger(__name__)


def cell_name(water: str, distance_m: float) -> str:
    """File-name stem of one cell (``coastal-1.5m``)."""
    w = re.sub(r"[^A-Za-z0-9_.-]+", "_", Path(str(water)).stem if str(water).endswith(".toml") else str(water))
    return f"{w}-{distance_m:g}m"


def sweep_optimum(doc: RigDoc, base: Setting, waters: list[str], distances_m: list[float], out: str | Path, *,
                  weights: Weights = DEFAULT_WEIGHTS, limits: dict | None = None, symmetric: bool | None = None,
                  seed: int = 0, progress=None, **search) -> list[dict]:
    """Optimise for every water × distance, resuming from the cells already in ``out``; the cells' records
    (:meth:`Optimum.record` plus ``water``, ``distance_m``, the rig file's text and ``code``, the
    :func:`~rigsim.code_version.code_version` that computed it).  A cell kept from a run with other settings or
    by other rigsim code is searched again (the latter with a warning)."""
    from rigsim.code_version import code_version, computed_here
    from rigsim.fileio import atomic_write_text, ensure_folder

    out = ensure_folder(out)
    cells = [(w, float(d)) for w in waters for d in distances_m]
    kept, stale = {}, []
    for w, d in cells:
        path = out / f"cell-{cell_name(w, d)}.json"
        try:
            rec = json.loads(path.read_text()) if path.exists() else None
        except (OSError, ValueError):
            rec = None  # half-written or damaged: redo
        if not isinstance(rec, dict) or \
                rec.get("key") != _key(doc, base, w, d, weights, limits, symmetric, seed, search):
            continue  # none, or made with other settings: redo
        if computed_here(rec):
            kept[(w, d)] = rec
        else:
            stale.append(path.name)
    if stale:
        log.warning("%d finished cell(s) in %s were found by other rigsim code (not %s): searching them again (%s)",
                    len(stale), out, code_version(), ", ".join(stale))
    rows = []
    for i, (w, d) in enumerate(cells):
        rec = kept.get((w, d))
        if rec is None:
            if progress:
                progress(i / len(cells), f"optimising for {w} at {d:g} m ({i + 1}/{len(cells)})")
            opt = optimise(doc, replace(base, water=w, distance_m=d), weights=weights, limits=limits,
                           symmetric=symmetric, seed=seed, **search)
            rec = opt.record()
            rec.update(water=w, distance_m=d, rig_toml=opt.best_doc.to_toml(), improvement=opt.improvement,
                       key=_key(doc, base, w, d, weights, limits, symmetric, seed, search))
            atomic_write_text(out / f"cell-{cell_name(w, d)}.json", json.dumps(rec, indent=1, default=str))
        rows.append(rec)
    if progress:
        progress(1.0, "sweep done")
    return rows


def _key(doc, base, w, d, weights, limits, symmetric, seed, search) -> str:
    return json.dumps([doc.to_toml(), asdict(replace(base, water=w, distance_m=d)), asdict(weights),
                       {k: list(v) if isinstance(v, tuple) else v for k, v in (limits or {}).items()}, symmetric, seed,
                       search], sort_keys=True, default=str)


def _span(values: list[float], fmt: str) -> str:
    lo, hi = min(values), max(values)
    return fmt.format(lo) if math.isclose(lo, hi, abs_tol=1e-9) or fmt.format(lo) == fmt.format(hi) \
        else f"{fmt.format(lo)}–{fmt.format(hi)}"


def _signed_span(values: list[float], fmt: str, unit: str, pos: str, neg: str, ref: str) -> str:
    """A span of signed values in words: "10–20 cm behind the lens", "from 5° inward to 30° outward"."""
    lo, hi = min(values), max(values)
    tail = f" {ref}" if ref else ""
    if lo >= 0 or hi <= 0:
        word = pos if lo >= 0 else neg
        a, b = sorted((abs(lo), abs(hi)))
        return f"{_span([a, b], fmt)}{unit} {word}{tail}"
    return f"from {fmt.format(-lo)}{unit} {neg} to {fmt.format(hi)}{unit} {pos}{tail}"


def water_sentence(rows: list[dict]) -> str:
    """One sentence for the cells of one water (a mirrored pair's arms, angles and beams)."""
    rows = sorted(rows, key=lambda r: r["distance_m"])
    water = rows[0]["water"]
    dist = _span([r["distance_m"] for r in rows], "{:g}") + " m"
    p = [r["best_placement"] for r in rows]
    if "arm length" in p[0] and "turned outward" in p[0]:
        arms = _span([x["arm length"] for x in p], "{:.2f}")
        elev = _signed_span([x["arm elevation"] for x in p], "{:.0f}", "°", "above", "below", "the horizontal")
        out_ = _signed_span([x["turned outward"] for x in p], "{:.0f}", "°", "outward", "inward", "")
        fwd = _signed_span([100 * x["forward offset"] for x in p], "{:.0f}", " cm", "ahead of", "behind",
                           "the lens")
        beams = sorted({x["beam angle"] for x in p if "beam angle" in x})
        beam = f", {'/'.join(f'{b:g}' for b in beams)}° beams" if beams else ""
        gain = _span([100 * r["improvement"] for r in rows if r.get("improvement") is not None and
                      math.isfinite(r["improvement"])] or [0.0], "{:.0f}")
        return (f"For {dist} in {water} water the arms should be {arms} m long, turned {out_} "
                f"(arms {elev}, {fwd}{beam}); {gain} % better than the rig as it was.")
    return f"For {dist} in {water} water: " + "; ".join(
        f"{r['distance_m']:g} m: " + ", ".join(f"{k} {v}" for k, v in r["best_placement"].items()) for r in rows)


def write_sweep(rows: list[dict], out: str | Path, *, rig_name: str) -> Path:
    """``sweep.csv``, ``sweep.png``, a rig file per cell and ``sweep.html`` into ``out``; returns the page."""
    import csv
    import html

    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    from rigsim.fileio import staged_output

    out = Path(out)
    keys = sorted({k for r in rows for k in r["best_placement"]}, key=list(rows[0]["best_placement"]).index)
    table = []
    for r in rows:
        table.append({"water": r["water"], "distance_m": r["distance_m"], **r["best_placement"],
                      "score_start": r["start"]["score"], "score_optimised": r["best"]["score"],
                      "improvement": r["improvement"],
                      **{f"optimised_{k}": v for k, v in r["best"]["metrics"].items()}})
    waters = list(dict.fromkeys(r["water"] for r in rows))
    sentences = [water_sentence([r for r in rows if r["water"] == w]) for w in waters]
    fig = Figure(figsize=(11, 3.6), dpi=100)
    axes = fig.subplots(1, 3)
    plotted = [("arm length", "arm length (m)"), ("turned outward", "turned outward (deg)")]
    for w in waters:
        rs = sorted([r for r in rows if r["water"] == w], key=lambda r: r["distance_m"])
        d = [r["distance_m"] for r in rs]
        for ax, (k, lab) in zip(axes[:2], plotted):
            if k in rs[0]["best_placement"]:
                ax.plot(d, [r["best_placement"][k] for r in rs], "o-", label=w)
                ax.set_ylabel(lab)
        axes[2].plot(d, [100 * r["improvement"] for r in rs], "o-", label=w)
    axes[2].set_ylabel("score better than the rig as it was (%)")
    for ax in axes:
        ax.set_xlabel("subject distance (m)")
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    with staged_output(out) as stage:
        with open(stage / "sweep.csv", "w", newline="") as fh:
            cols = list(dict.fromkeys(k for t in table for k in t))
            wr = csv.DictWriter(fh, fieldnames=cols, lineterminator="\n")
            wr.writeheader()
            wr.writerows(table)
        (stage / "sweep.png").write_bytes(buf.getvalue())
        for r in rows:
            (stage / f"{rig_name}-{cell_name(r['water'], r['distance_m'])}.toml").write_text(r["rig_toml"])
        head = "".join(f"<th>{html.escape(k)}</th>" for k in ["water", "distance (m)", *keys, "better by"])
        body = "".join(
            "<tr>" + "".join(f"<td>{html.escape(str(v))}</td>" for v in
                             [r["water"], f"{r['distance_m']:g}", *[r["best_placement"].get(k, "") for k in keys],
                              f"{100 * r['improvement']:.0f} %"]) + "</tr>" for r in rows)
        import base64

        page = ("<!doctype html><meta charset='utf-8'><title>rigsim optimise: sweep</title>"
                "<style>body{font-family:sans-serif;max-width:1100px;margin:1em auto}table{border-collapse:collapse}"
                "td,th{border:1px solid #ccc;padding:.2em .6em;text-align:right}th{background:#eee}</style>"
                f"<h1>Where the strobes of {html.escape(rig_name)} go, by distance and water</h1><ul>"
                + "".join(f"<li><b>{html.escape(s)}</b></li>" for s in sentences) + "</ul>"
                + f"<img width='1050' src='data:image/png;base64,{base64.b64encode(buf.getvalue()).decode()}'>"
                + f"<table><tr>{head}</tr>{body}</table>"
                "<p>Each row is one optimisation (fast engine; the rig files are beside this page). Arm elevation: "
                "the right arm's angle above the horizontal (the left one mirrors it); forward offset: + = ahead "
                "of the entrance pupil.</p>")
        (stage / "sweep.html").write_text(page)
    return out / "sweep.html"
