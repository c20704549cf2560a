"""What a diver gets back from an optimisation: a rig file, pictures, numbers and a sentence.

:func:`sensitivities` moves the optimum one diver's step at a time (:data:`~rigsim.optimise.space.SENSITIVITY_STEPS`:
10 cm of arm, 10–15° of angle, the other diffuser) and measures what changes; :func:`verify` renders
the start and the optimum with the Monte Carlo renderer (several seeds, so each number has its
standard error) and says whether the improvement holds there; :func:`write_optimum` writes, each
file atomically into ``out`` (a staging folder moved in at the end, so a killed run leaves the
folder as it was):

``<rig>-optimised.toml``
    The optimised rig file (loads with ``rigsim`` like any other), with the setting in its header.
``diagram.png``
    Top view and view from behind of the rig before (grey) and after (:mod:`rigsim.optimise.diagram`).
``before.png``, ``after.png``
    The predicted photographs (fast engine, :data:`~rigsim.optimise.objective.FINAL` size, the sensor's
    auto exposure and white balance).
``metrics.csv``, ``sensitivities.csv``, ``verification.csv``, ``result.json``
    The numbers.
``report.html``
    All of it on one page (opens offline).
"""

from __future__ import annotations

import csv
import html
import io
import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rigsim.optimise.objective import FINAL, METRICS, REPORT, Weights, measure, photo, scene_for
from rigsim.optimise.search import Evaluator, Optimum
from rigsim.optimise.space import SENSITIVITY_STEPS

__all__ = ["Sensitivity", "Verification", "sensitivities", "verify", "write_optimum", "sentence", "VERIFY_SEEDS",
           "VERIFY_SPP", "VERIFY_WIDTH"]

#: Monte Carlo check of the start and the optimum: image width (px), seeds and paths per pixel per seed
#: (a 96-px-wide chart filling 60 % of the frame has patches of 6×6 px after erosion).
VERIFY_WIDTH, VERIFY_SEEDS, VERIFY_SPP = 96, 4, 32
#: Metrics the Monte Carlo check compares (the radiance's own; the sensor's are the same function of it).
VERIFIED = ("backscatter_share", "evenness_cv", "corner_ratio", "contrast")


@dataclass(frozen=True)
class Sensitivity:
    """The optimum moved by one step of one parameter (``change`` in the parameter's unit, or the other
    beam), and the relative change of each metric and of the score."""

    label: str
    change: str
    metrics: dict[str, float]
    score_change: float
    infeasible: str | None = None


def _rel(new: float | None, old: float | None) -> float:
    if new is None or old is None or not (math.isfinite(new) and math.isfinite(old)) or old == 0:
        return float("nan")
    return new / old - 1.0


def sensitivities(opt: Optimum, evaluator: Evaluator | None = None) -> list[Sensitivity]:
    """One step of each searched parameter away from the optimum (towards the inside of its limits),
    measured at :data:`~rigsim.optimise.objective.REPORT` fidelity."""
    ev = evaluator or Evaluator(opt.space, opt.setting, opt.weights, REPORT, opt.seed)
    base = opt.best
    out = []
    for j, p in enumerate(opt.space.parameters):
        x = opt.best_x.copy()
        if p.options:
            if len(p.options) < 2:
                continue
            k = int(round(x[j]))
            k2 = 1 - k if len(p.options) == 2 else (k + 1) % len(p.options)
            x[j] = k2
            change = f"beam {p.options[k]:g}° → {p.options[k2]:g}°"
        else:
            step = SENSITIVITY_STEPS.get(p.key, 0.1 * (p.hi - p.lo))
            if p.hi <= p.lo:
                continue
            d = step if x[j] + step <= p.hi + 1e-9 else -step
            if x[j] + d < p.lo - 1e-9:
                d = p.hi - x[j] if abs(p.hi - x[j]) > abs(p.lo - x[j]) else p.lo - x[j]
            x[j] = x[j] + d
            unit = " m" if p.unit == "m" else "°"
            change = f"{d:+.2f}{unit}" if p.unit == "m" else f"{d:+.0f}{unit}"
        try:
            doc = opt.space.apply(x)
            e = ev.evaluation(doc, REPORT)
        except Exception as exc:  # a move the rig reader refuses
            out.append(Sensitivity(p.label, change, {}, float("nan"), infeasible=str(exc).split(": ")[-1]))
            continue
        if e.infeasible:
            out.append(Sensitivity(p.label, change, {}, float("nan"), infeasible=e.infeasible))
            continue
        rel = {k: _rel(e.metrics.get(k), base.metrics.get(k)) for k in METRICS}
        out.append(Sensitivity(p.label, change, rel, _rel(e.score(opt.weights), base.score(opt.weights))))
    return out


@dataclass(frozen=True)
class Verification:
    """Monte Carlo measurement of the start and the optimum: mean and standard error over seeds of
    :data:`VERIFIED`, with the fast engine's numbers at the same size, and whether the optimum is better
    than the start there beyond the 95 % interval of the difference (t · its standard error), on the
    radiance score (the backscatter and evenness terms)."""

    start_mc: dict[str, float]
    start_mc_se: dict[str, float]
    best_mc: dict[str, float]
    best_mc_se: dict[str, float]
    start_fast: dict[str, float]
    best_fast: dict[str, float]
    radiance_score_start: float
    radiance_score_best: float
    radiance_score_se: float
    holds: bool
    width: int
    height: int
    seeds: int
    spp: int
    seconds: float


def _radiance_score(m: dict, w: Weights) -> float:
    return w.backscatter * m.get("backscatter_share", 0.0) + w.evenness * m.get("evenness_cv", 0.0)


def verify(opt: Optimum, *, width: int = VERIFY_WIDTH, seeds: int = VERIFY_SEEDS, spp: int = VERIFY_SPP,
           progress=None) -> Verification:
    """Render the start and the optimum with :func:`rigsim.render.render` (``seeds`` × ``spp``) and compare."""
    import time

    from rigsim.optimise.objective import Fidelity, image_height, render_fast
    from rigsim.render import render

    t0 = time.perf_counter()
    layers = ("range_m", "object_id", "direct", "backscatter")
    fid = Fidelity("verify", width)
    res = {}
    total = 2 * seeds
    done = 0
    for name, doc in (("start", opt.start_doc), ("best", opt.best_doc)):
        rig = doc.rig()
        h = image_height(rig, width)
        scene = scene_for(rig, opt.setting)
        per_seed = []
        for s in range(seeds):
            si = render(scene, width=width, height=h, spp=spp, seed=1000 + s, wavelengths_nm=fid.wavelengths_nm,
                        layers=layers)
            per_seed.append(measure(si, opt.setting, seed=s))
            done += 1
            if progress:
                progress(done / total, f"Monte Carlo check: {name} seed {s + 1}/{seeds}")
        fast = measure(render_fast(scene, width, h, fid), opt.setting)
        keys = [k for k in VERIFIED if all(k in m for m in per_seed)]
        arr = {k: np.array([m[k] for m in per_seed]) for k in keys}
        rs = np.array([_radiance_score(m, opt.weights) for m in per_seed])
        res[name] = ({k: float(v.mean()) for k, v in arr.items()},
                     {k: float(v.std(ddof=1) / math.sqrt(len(v))) if len(v) > 1 else float("nan")
                      for k, v in arr.items()}, {k: fast[k] for k in keys if k in fast}, rs)
    (s_m, s_se, s_f, s_rs), (b_m, b_se, b_f, b_rs) = res["start"], res["best"]
    se = math.sqrt((s_rs.var(ddof=1) + b_rs.var(ddof=1)) / seeds) if seeds > 1 else float("nan")
    from rigsim.metrics.agreement import noise_multiplier

    # better beyond the 95 % interval of the difference (Student's t for the seeds, as the studies' checks)
    holds = bool(b_rs.mean() < s_rs.mean() - noise_multiplier(seeds) * se) if math.isfinite(se) \
        else bool(b_rs.mean() < s_rs.mean())
    return Verification(start_mc=s_m, start_mc_se=s_se, best_mc=b_m, best_mc_se=b_se, start_fast=s_f, best_fast=b_f,
                        radiance_score_start=float(s_rs.mean()), radiance_score_best=float(b_rs.mean()),
                        radiance_score_se=se, holds=holds, width=width, height=image_height(opt.best_doc.rig(), width),
                        seeds=seeds, spp=spp, seconds=time.perf_counter() - t0)


# ----------------------------------------------------------------------------- words

def _fmt_metric(key: str, v: float | None) -> str:
    if v is None or not math.isfinite(v):
        return "–"
    unit = METRICS[key][1]
    if key == "speck_light":
        return f"{100 * v:.2f} %"
    if unit == "%":
        return f"{100 * v:.1f} %"
    if key in ("snr_white", "iso", "speck_count"):
        return f"{v:.0f}"
    if key == "delta_e_mean":
        return f"{v:.1f}"
    return f"{v:.3f}" if abs(v) < 10 else f"{v:.1f}"


def _fmt_se(key: str, v: float | None) -> str:
    """A standard error to two significant digits (in % for shares)."""
    if v is None or not math.isfinite(v):
        return "–"
    return f"{100 * v:.2g} %" if METRICS[key][1] == "%" else f"{v:.2g}"


def _placement_words(opt: Optimum) -> str:
    """The optimum's placement in a diver's words."""
    d = opt.space.describe_doc(opt.best_doc)
    if opt.space.pair is not None:
        elev = d["arm elevation"]
        fwd = d["forward offset"]
        yaw = d["turned outward"]
        parts = [f"arms {d['arm length']:.2f} m", f"{abs(elev):.0f}° {'above' if elev >= 0 else 'below'} the horizontal"]
        if abs(fwd) >= 0.02:
            parts.append(f"{abs(fwd) * 100:.0f} cm {'behind' if fwd < 0 else 'ahead of'} the lens")
        parts.append(f"strobes turned {abs(yaw):.0f}° {'outward' if yaw >= 0 else 'inward'}")
        if abs(d["pitch"]) >= 2:
            parts.append(f"{abs(d['pitch']):.0f}° {'up' if d['pitch'] > 0 else 'down'}")
        if "beam angle" in d:
            parts.append(f"{d['beam angle']:g}° beams")
        return ", ".join(parts)
    names = opt.best_doc.light_names()
    out = []
    for i, name in enumerate(names):
        v = opt.best_doc.light_view(i)
        out.append(f"{name} on a {v['arm_length_m']:.2f} m arm at {v['arm_angle_deg']:.0f}° "
                   f"({v['arm_forward_m'] * 100:+.0f} cm along the lens), yaw {v['yaw_deg']:+.0f}°, "
                   f"pitch {v['pitch_deg']:+.0f}°, {v['beam_angle_deg']:g}° beam")
    return "; ".join(out)


def sentence(opt: Optimum) -> str:
    """One sentence a diver can act on."""
    s0, s1 = opt.start.metrics, opt.best.metrics
    if opt.best_doc is opt.start_doc:
        return (f"For {opt.setting.label()}, keep the rig as it is: no placement within the limits scored better "
                f"once measured with multiple scattering.")
    changes = []
    for k in ("backscatter_share", "evenness_cv", "snr_white", "delta_e_mean", "speck_light", "speck_count"):
        if k in s0 and k in s1:
            changes.append(f"{METRICS[k][0]} {_fmt_metric(k, s0[k])} → {_fmt_metric(k, s1[k])}")
    return (f"For {opt.setting.label()}: {_placement_words(opt)} — " + ", ".join(changes)
            + f" (score {opt.start.score(opt.weights):.3f} → {opt.best.score(opt.weights):.3f}, "
              f"{100 * opt.improvement:.0f} % better).")


def sensitivity_sentence(s: Sensitivity) -> str:
    if s.infeasible:
        return f"{s.label} {s.change}: not usable ({s.infeasible})"
    bits = []
    for k in ("backscatter_share", "corner_ratio", "evenness_cv", "snr_white", "delta_e_mean", "speck_light"):
        v = s.metrics.get(k)
        if v is not None and math.isfinite(v) and abs(v) >= 0.005:
            bits.append(f"{METRICS[k][0]} {100 * v:+.0f} %")
    core = ", ".join(bits) if bits else "no change above 0.5 %"
    return f"{s.label} {s.change}: {core} (score {100 * s.score_change:+.0f} %)"


# ----------------------------------------------------------------------------- files

def _csv(rows: list[dict]) -> str:
    buf = io.StringIO()
    if rows:
        w = csv.DictWriter(buf, fieldnames=list(rows[0]), lineterminator="\n")
        w.writeheader()
        w.writerows(rows)
    return buf.getvalue()


def _metric_rows(opt: Optimum) -> list[dict]:
    rows = []
    for k, (label, unit, better) in METRICS.items():
        a, b = opt.start.metrics.get(k), opt.best.metrics.get(k)
        if a is None and b is None:
            continue
        rows.append({"metric": k, "label": label, "better": better, "start": a, "optimised": b,
                     "change": _rel(b, a)})
    rows.append({"metric": "score", "label": "score (lower is better)", "better": "lower",
                 "start": opt.start.score(opt.weights), "optimised": opt.best.score(opt.weights),
                 "change": _rel(opt.best.score(opt.weights), opt.start.score(opt.weights))})
    return rows


def _img(data: bytes, alt: str, width: int | None = None) -> str:
    import base64

    w = f' width="{width}"' if width else ""
    return f'<img alt="{html.escape(alt)}"{w} src="data:image/png;base64,{base64.b64encode(data).decode()}">'


def _table(rows: list[dict], cols: list[tuple[str, str]]) -> str:
    head = "".join(f"<th>{html.escape(t)}</th>" for _, t in cols)
    body = "".join("<tr>" + "".join(f"<td>{html.escape(str(r.get(k, '')))}</td>" for k, _ in cols) + "</tr>"
                   for r in rows)
    return f"<table><tr>{head}</tr>{body}</table>"


def write_optimum(opt: Optimum, out: str | Path, *, check: bool = True, photo_width: int = FINAL.width,
                  progress=None) -> Path:
    """Write the optimisation's files into ``out`` (see the module docstring); returns ``report.html``.

    ``check`` renders the Monte Carlo verification (:func:`verify`); ``photo_width`` is the photographs' width.
    """
    from rigsim.fileio import png_bytes, staged_output
    from rigsim.optimise.diagram import rig_diagram
    from rigsim.optimise.objective import Fidelity

    tick = progress or (lambda f, m: None)
    out = Path(out)
    name = f"{opt.start_doc.name}-optimised"
    tick(0.0, "sensitivities")
    sens = sensitivities(opt)
    tick(0.3, "photographs")
    fid = Fidelity("final", int(photo_width))
    before, after = (photo(d.rig(), opt.setting, fid, seed=opt.seed) for d in (opt.start_doc, opt.best_doc))
    ver = None
    if check:
        ver = verify(opt, progress=lambda f, m: tick(0.5 + 0.45 * f, m))
    words = sentence(opt)
    record = opt.record()
    record["sentence"] = words
    record["sensitivities"] = [s.__dict__ for s in sens]
    record["verification"] = None if ver is None else ver.__dict__
    header = (f"Optimised by `rigsim optimise` from {opt.start_doc.source} for {opt.setting.label()}\n"
              f"({opt.setting.sensor}, subject {opt.setting.subject}); score {opt.start.score(opt.weights):.4g} → "
              f"{opt.best.score(opt.weights):.4g} (lower is better)\nscore = {_score_words(opt.weights)}.\n{words}")
    with staged_output(out) as stage:
        (stage / f"{name}.toml").write_text(opt.best_doc.relocated(out.resolve(), f"{name}.toml").to_toml(header=header))
        cam = opt.best_doc.rig().camera
        from rigsim.scene.optics import field_width_m

        width_m = opt.setting.subject_fill * field_width_m(cam, opt.setting.distance_m)
        rig_diagram(opt.best_doc.rig(), opt.start_doc.rig(), distance_m=opt.setting.distance_m,
                    subject_width_m=width_m, out_png=stage / "diagram.png",
                    title=f"{opt.start_doc.name}: optimised for {opt.setting.label()}")
        (stage / "before.png").write_bytes(png_bytes(before))
        (stage / "after.png").write_bytes(png_bytes(after))
        metric_rows = _metric_rows(opt)
        (stage / "metrics.csv").write_text(_csv(metric_rows))
        (stage / "sensitivities.csv").write_text(_csv(
            [{"parameter": s.label, "change": s.change, **{k: s.metrics.get(k) for k in METRICS},
              "score": s.score_change, "not_usable": s.infeasible or ""} for s in sens]))
        if ver is not None:
            vrows = []
            for k in VERIFIED:
                vrows.append({"metric": k, "start_fast": ver.start_fast.get(k), "start_mc": ver.start_mc.get(k),
                              "start_mc_se": ver.start_mc_se.get(k), "optimised_fast": ver.best_fast.get(k),
                              "optimised_mc": ver.best_mc.get(k), "optimised_mc_se": ver.best_mc_se.get(k)})
            (stage / "verification.csv").write_text(_csv(vrows))
        (stage / "result.json").write_text(json.dumps(record, indent=1, default=_json_default))
        (stage / "report.html").write_text(_page(opt, words, sens, ver, metric_rows, stage, name))
    tick(1.0, "written")
    return out / "report.html"


def _json_default(o):
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, (np.floating, np.integer)):
        return o.item()
    return str(o)


def _page(opt: Optimum, words: str, sens: list[Sensitivity], ver: Verification | None, metric_rows: list[dict],
          stage: Path, name: str) -> str:
    f = lambda k, v: _fmt_metric(k, v) if k in METRICS else (f"{v:.4g}" if isinstance(v, float) else v)  # noqa: E731
    mrows = [{"label": r["label"], "start": f(r["metric"], r["start"]), "optimised": f(r["metric"], r["optimised"]),
              "change": "–" if not math.isfinite(r["change"]) else f"{100 * r['change']:+.0f} %",
              "better": r["better"]} for r in metric_rows]
    parts = [
        "<!doctype html><meta charset='utf-8'><title>rigsim optimise: " + html.escape(name) + "</title>",
        "<style>body{font-family:sans-serif;max-width:1100px;margin:1em auto;padding:0 1em}"
        "table{border-collapse:collapse;margin:.5em 0}td,th{border:1px solid #ccc;padding:.2em .6em;text-align:right}"
        "th{background:#eee}td:first-child{text-align:left}.pics img{max-width:49%}</style>",
        f"<h1>Strobe placement for {html.escape(opt.setting.label())}</h1>",
        f"<p><b>{html.escape(words)}</b></p>",
        f"<p>Rig file: <a href='{html.escape(name)}.toml'>{html.escape(name)}.toml</a> "
        f"(from {html.escape(opt.start_doc.source)}). Sensor {html.escape(opt.setting.sensor)}, subject "
        f"{html.escape(opt.setting.subject)} filling {100 * opt.setting.subject_fill:.0f} % of the frame width. "
        f"Searched {opt.evaluations} placements in {opt.seconds:.0f} s (seed {opt.seed}).</p>",
        "<h2>The rig before and after</h2>", _img((stage / "diagram.png").read_bytes(), "rig diagram", 1050),
        "<h2>Predicted photographs</h2><div class='pics'>",
        _img((stage / "before.png").read_bytes(), "before"), " ", _img((stage / "after.png").read_bytes(), "after"),
        "</div><p>Left: the starting rig; right: optimised (fast engine, the sensor's auto exposure and white "
        "balance).</p>",
        "<h2>Numbers</h2>",
        _table(mrows, [("label", "metric"), ("start", "start"), ("optimised", "optimised"), ("change", "change"),
                       ("better", "better")]),
        f"<p>Score = {html.escape(_score_words(opt.weights))}. Measured with the fast engine at "
        f"{REPORT.width} px (multiple scattering where the water needs it).</p>",
        "<h2>What matters: one step away from the optimum</h2><ul>",
        *[f"<li>{html.escape(sensitivity_sentence(s))}</li>" for s in sens], "</ul>",
    ]
    if ver is not None:
        vr = []
        for k in VERIFIED:
            if k not in ver.best_mc:
                continue
            vr.append({"m": METRICS[k][0],
                       "sf": _fmt_metric(k, ver.start_fast.get(k)),
                       "sm": f"{_fmt_metric(k, ver.start_mc.get(k))} ± {_fmt_se(k, ver.start_mc_se.get(k))}",
                       "bf": _fmt_metric(k, ver.best_fast.get(k)),
                       "bm": f"{_fmt_metric(k, ver.best_mc.get(k))} ± {_fmt_se(k, ver.best_mc_se.get(k))}"})
        verdict = ("The improvement holds in the Monte Carlo render" if ver.holds else
                   "The Monte Carlo render does NOT confirm the improvement beyond its noise")
        parts += [
            "<h2>Checked by Monte Carlo</h2>",
            f"<p>{verdict}: backscatter + unevenness terms {ver.radiance_score_start:.3f} → "
            f"{ver.radiance_score_best:.3f} (standard error of the difference {ver.radiance_score_se:.2g}); {ver.width}×{ver.height} px, "
            f"{ver.seeds} seeds × {ver.spp} paths per pixel, {ver.seconds:.0f} s.</p>",
            _table(vr, [("m", "metric"), ("sf", "start, fast"), ("sm", "start, Monte Carlo"),
                        ("bf", "optimised, fast"), ("bm", "optimised, Monte Carlo")])]
    if opt.notes:
        parts += ["<h2>Notes</h2><ul>", *[f"<li>{html.escape(n)}</li>" for n in opt.notes], "</ul>"]
    lim = [{"p": p.label, "lo": "–" if p.options else f"{p.lo:g}", "hi": "–" if p.options else f"{p.hi:g}",
            "opts": "/".join(f"{o:g}" for o in p.options)}
           for p in opt.space.parameters]
    parts += ["<h2>Searched within</h2>",
              _table(lim, [("p", "parameter"), ("lo", "low"), ("hi", "high"), ("opts", "beam options (deg)")])]
    return "\n".join(parts) + "\n"


def _score_words(w: Weights) -> str:
    return (f"{w.backscatter:g} × backscatter share + {w.evenness:g} × unevenness (CV) + {w.noise:g} × 10/SNR + "
            f"{w.colour:g} × ΔE2000/10 + {w.specks:g} × lit specks' light share (%)")
