"""The study report: one self-contained HTML file (plots and images inline, opens offline)."""

from __future__ import annotations

import base64
import csv
import html
import io
import json
from collections import defaultdict
from pathlib import Path

import numpy as np

from rigsim.fileio import atomic_write_text

__all__ = ["write_report", "summary_sentences", "sensor_sentences", "noise_sentences", "trust_sentences",
           "trust_section", "speck_sentences"]


def _read_csv(path: Path) -> list[dict]:
    if not path.is_file():
        return []
    with path.open() as fh:
        rows = list(csv.DictReader(fh))
    for r in rows:
        for k, v in r.items():
            try:
                r[k] = float(v) if v not in ("", None) else None
            except ValueError:
                pass
    return rows


def _png(fig) -> str:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100)
    import matplotlib.pyplot as plt

    plt.close(fig)
    return "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode()


def _img_file(path: Path) -> str:
    return "data:image/png;base64," + base64.b64encode(path.read_bytes()).decode()


def _thumb(path: Path, width: int = 320) -> str:
    """A JPEG thumbnail of an image file, inline (the full-size file is linked beside it)."""
    import cv2

    img = cv2.imread(str(path), cv2.IMREAD_COLOR)
    if img is None:
        return _img_file(path)
    if img.shape[1] > width:
        img = cv2.resize(img, (width, max(1, round(img.shape[0] * width / img.shape[1]))), interpolation=cv2.INTER_AREA)
    ok, buf = cv2.imencode(".jpg", img, [cv2.IMWRITE_JPEG_QUALITY, 85])
    return "data:image/jpeg;base64," + base64.b64encode(buf.tobytes()).decode() if ok else _img_file(path)


def _is_extension(r: dict) -> bool:
    return r.get("extension") in (True, "True", 1.0)


def _fmt_m(x, searched_to=None, se=None) -> str:
    """A range in m; with its standard error ``se`` (m) where one was measured."""
    if x is None or (isinstance(x, float) and np.isnan(x)):
        return "n/a"
    if np.isinf(x):
        return f"beyond {searched_to:.0f} m" if searched_to else "beyond the sweep"
    if se is not None and np.isfinite(se) and se >= 0.05:
        return f"{x:.1f} ± {se:.1f} m"
    return f"{x:.1f} m"


def _fmt_vis(r: dict) -> str:
    """A visibility range with how it was found (the sweep, or the fast engine beyond it)."""
    v, sweep_max = r.get("visibility_m_radiance"), r.get("sweep_max_m")
    far, end = r.get("contrast_at_searched_end"), r.get("searched_to_m")
    if v is not None and not np.isfinite(v) and far is not None and end is not None and sweep_max is not None \
            and end > sweep_max and abs(far) >= r.get("threshold", 0.0):
        return (f"not found: the contrast levels off at {far:.1%} out to {end:.0f} m (a contrast that does not "
                f"fall with distance is not the target's: the strobes' veil differs between the target and the "
                f"water around it)")
    txt = _fmt_m(v, end, r.get("visibility_m_radiance_se"))
    if v is not None and sweep_max is not None and np.isfinite(v) and v > sweep_max:
        txt += " (found beyond the sweep by the fast engine)"
    return txt


def summary_sentences(vis: list[dict], *, sensor: str | None = None, target: str | None = None) -> list[str]:
    """Plain-language comparison of the rigs per water, from the visibility table."""
    by_water: dict[str, list[dict]] = defaultdict(list)
    for r in vis:
        if (sensor is None or r["sensor"] == sensor) and (target is None or r["target"] == target):
            by_water[r["water"]].append(r)
    out = []
    for water, rs in by_water.items():
        rs = sorted(rs, key=lambda r: -(r.get("visibility_m_radiance") or 0))
        parts = [f"{r['rig']}: {v}" if (v := _fmt_vis(r)).startswith("not found") else f"{r['rig']} to {v}"
                 for r in rs]
        thr = rs[0]["threshold"] * 100
        out.append(f"In {water} water ({rs[0]['target']}), contrast stays above {thr:g} %: " + ", ".join(parts) + ".")
    return out


def noise_sentences(rows: list[dict], noise_target: float | None, max_spp: int | None) -> list[str]:
    """Which scenes stopped at ``max_spp`` with Monte Carlo noise above ``noise_target``.

    ``rows``: results.csv rows (``mc_noise_p99`` per scene, repeated per sensor).  Their images
    show render speckle and their image-based metrics (ΔE, SNR, image contrast) carry it; the
    scene-radiance contrast and the visibility range are affected less (averages over regions).
    """
    if not noise_target:
        return []
    scenes: dict[tuple, float] = {}
    for r in rows:
        n = r.get("mc_noise_p99")
        key = (r.get("rig"), r.get("water"), r.get("target"), r.get("distance_m"))
        if n is not None:
            scenes[key] = max(n, scenes.get(key, 0.0))
    noisy: dict[tuple, list] = defaultdict(list)
    for (rig, water, target, dist), n in scenes.items():
        if n > noise_target:
            noisy[(rig, water, target)].append((dist, n))
    if not scenes:
        return []
    if not noisy:
        return [f"Every scene reached the Monte Carlo noise target ({noise_target:g} of the local mean at the "
                f"99th percentile of pixels)."]
    n_noisy = sum(len(v) for v in noisy.values())
    parts = []
    for (rig, water, target), v in sorted(noisy.items(), key=lambda kv: tuple(str(x) for x in kv[0])):
        v.sort(key=lambda x: x[0])
        dists = ", ".join(f"{d:g}" for d, _ in v)
        parts.append(f"{rig} in {water} ({target}) at {dists} m (noise up to {max(n for _, n in v):.2f})")
    return [f"{n_noisy} of {len(scenes)} scenes stopped at {max_spp} paths per pixel with Monte Carlo noise above the "
            f"target {noise_target:g}: " + "; ".join(parts) + ". Their images show render speckle, and their "
            f"ΔE, SNR and image contrast carry it."]


def sensor_sentences(rows: list[dict], sensors: list[str]) -> list[str]:
    """Plain-language comparison of the sensors: median SNR and ΔE over all cases of each."""
    out = []
    parts = []
    for s in sensors:
        snr = [r["snr_white"] for r in rows if r.get("sensor") == s and r.get("snr_white")]
        de = [r["delta_e_mean"] for r in rows if r.get("sensor") == s and r.get("delta_e_mean") is not None]
        if snr:
            txt = f"{s} SNR {np.median(snr):.0f} ({20 * np.log10(np.median(snr)):.0f} dB)"
            if de:
                txt += f", chart ΔE2000 {np.median(de):.1f}"
            parts.append(txt)
    if parts:
        out.append("Sensors (medians over all waters, rigs and distances): " + "; ".join(parts) + ".")
    return out


def speck_sentences(rows: list[dict]) -> list[str]:
    """Per water with discrete particles (marine snow) and target: each rig's visible specks and their share
    of the light (:mod:`rigsim.metrics.specks`) at each distance of the sweep, and at how many distances
    each rig lights fewer specks than the others."""
    scenes: dict[tuple, dict] = {}
    for r in rows:  # one row per sensor: the scene's numbers
        if r.get("speck_count") is not None and not _is_extension(r):
            scenes[(r["water"], r["target"], r["rig"], r["distance_m"])] = r
    out = []
    for water, target in dict.fromkeys((k[0], k[1]) for k in scenes):
        rigs = list(dict.fromkeys(k[2] for k in scenes if k[:2] == (water, target)))
        dists = sorted({k[3] for k in scenes if k[:2] == (water, target)})
        level = next(r for k, r in scenes.items() if k[:2] == (water, target)).get("particles_level")
        parts = []
        for rig in rigs:
            per = [scenes.get((water, target, rig, d)) for d in dists]
            counts = " / ".join("–" if p is None else f"{p['speck_count']:.0f}" for p in per)
            shares = " / ".join("–" if p is None else f"{100 * p['speck_share']:.1f}" for p in per)
            parts.append(f"{rig} {counts} specks ({shares} % of the light)")
        txt = (f"Marine snow in {water} (particle level {level}), {target} at "
               f"{' / '.join(f'{d:g}' for d in dists)} m: " + "; ".join(parts))
        if len(rigs) > 1:
            wins = {rig: sum(1 for d in dists if all(
                (scenes.get((water, target, rig, d)) or {}).get("speck_share", np.inf)
                < (scenes.get((water, target, o, d)) or {}).get("speck_share", np.inf) for o in rigs if o != rig))
                for rig in rigs}
            best = max(wins, key=wins.get)
            txt += f" — {best} puts the smallest share of the light into specks at {wins[best]} of {len(dists)} distances"
        out.append(txt + ".")
    return out


def write_report(study_dir: str | Path) -> Path:
    """Write ``report.html`` into a study folder from its tables and images."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    d = Path(study_dir)
    spec = json.loads((d / "study.json").read_text())
    rows = _read_csv(d / "results.csv")
    sweep_rows = [r for r in rows if not _is_extension(r)]
    vis = _read_csv(d / "visibility.csv")
    agreement = _read_csv(d / "agreement.csv")
    timings = _read_csv(d / "timings.csv")
    waters = list(dict.fromkeys(spec["water_names"]))
    rigs = list(dict.fromkeys(spec["rig_names"]))
    from rigsim.study.spec import sensor_key

    sensors = [sensor_key(s) for s in spec["sensors"]]
    targets = [Path(t).name for t in spec["targets"]]
    thr = spec["contrast_threshold"]

    sec: list[str] = []
    # ------------------------------------------------------------------ summary
    items = []
    for t in targets:
        items += summary_sentences(vis, sensor=sensors[0] if sensors else None, target=t)
    items += sensor_sentences(rows, sensors)
    items += speck_sentences(rows)
    r_spec = spec["render"]
    if r_spec["engine"] != "preview":
        items += noise_sentences(rows, r_spec.get("noise_target"), r_spec.get("max_spp") or 8 * r_spec["spp"])
    items += trust_sentences(agreement, r_spec)
    sec.append("<h2>Summary</h2><ul>" + "".join(f"<li>{html.escape(s)}</li>" for s in items) + "</ul>"
               + f"<p>Visibility range: the distance at which the target's apparent contrast (luminance, "
                 f"noise-free scene radiance) falls below {thr * 100:g} %, interpolated in log-contrast over "
                 f"the distance sweep.</p>")

    # ------------------------------------------------------------------ plots
    def per_water_plot(ycol: str, ylabel: str, *, logy=False, hline=None, target=None):
        fig, axes = plt.subplots(1, len(waters), figsize=(4.2 * len(waters), 3.6), squeeze=False, sharey=True)
        for ax, w in zip(axes[0], waters):
            for rig in rigs:
                for s in sensors:
                    rs = [r for r in sweep_rows if r["water"] == w and r["rig"] == rig and r["sensor"] == s
                          and (target is None or r["target"] == target) and r.get(ycol) is not None]
                    rs.sort(key=lambda r: r["distance_m"])
                    if rs:
                        ax.plot([r["distance_m"] for r in rs], [r[ycol] for r in rs], "o-", ms=3,
                                label=f"{rig} / {s}")
            if hline is not None:
                ax.axhline(hline, color="k", ls=":", lw=1)
            if logy:
                ax.set_yscale("log")
            ax.set_title(w)
            ax.set_xlabel("distance (m)")
            ax.grid(alpha=0.3)
        axes[0][0].set_ylabel(ylabel)
        axes[0][-1].legend(fontsize=7)
        fig.tight_layout()
        return _png(fig)

    for t in targets:
        parts = []
        for col, label, logy, hline in (
                ("contrast_radiance", "contrast (scene radiance)", True, thr),
                ("contrast_image", "contrast (developed image)", True, thr),
                ("delta_e_mean", "mean ΔE2000 of the chart", False, None),
                ("snr_white", "sensor SNR (EMVA 1288) of the reference region", True, None),
                ("backscatter_share", "backscatter share of the target's signal", False, None)):
            if any(r.get(col) is not None and r["target"] == t for r in rows):
                parts.append(f"<h3>{html.escape(label[0].upper() + label[1:])}</h3>"
                             f"<img src='{per_water_plot(col, label, logy=logy, hline=hline, target=t)}'>")
        if parts:
            sec.append(f"<h2>Versus distance — {html.escape(t)}</h2>" + "".join(parts))
    snow = [w for w in waters if any(r.get("speck_count") is not None and r["water"] == w for r in sweep_rows)]
    if snow:
        fig, axes = plt.subplots(2, len(snow), figsize=(4.6 * len(snow), 6.4), squeeze=False)
        for j, w in enumerate(snow):
            for rig in rigs:
                for t in targets:
                    per = {r["distance_m"]: r for r in sweep_rows if r["water"] == w and r["rig"] == rig
                           and r["target"] == t and r.get("speck_count") is not None}
                    ds = sorted(per)
                    if not ds:
                        continue
                    axes[0][j].plot(ds, [per[x]["speck_count"] for x in ds], "o-", ms=3, label=f"{rig} / {t}")
                    axes[1][j].plot(ds, [per[x]["speck_share"] * 100 for x in ds], "o-", ms=3, label=f"{rig} / {t}")
            axes[0][j].set_title(w)
            axes[1][j].set_xlabel("distance to the subject (m)")
            for ax in axes[:, j]:
                ax.grid(alpha=0.3)
        axes[0][0].set_ylabel("visible specks")
        axes[1][0].set_ylabel("specks' share of the light (%)")
        axes[0][-1].legend(fontsize=7)
        fig.tight_layout()
        sec.append("<h2>Backscatter specks (marine snow)</h2>"
                   f"<img src='{_png(fig)}'><p>A speck is a particle with a pixel where its light is at least "
                   f"5 % of the subject's mean luminance (scene radiance, one flash; rigsim.metrics.specks); its share "
                   f"is the particles' light as a fraction of the whole image's.  Fewer and dimmer specks is better: "
                   f"strobes farther out and aimed past the subject light less of the water just in front of the "
                   f"port, where the brightest specks and the large out-of-focus discs are.</p>")
    if vis:
        fig, axes = plt.subplots(1, len(targets), figsize=(6 * len(targets), 3.8), squeeze=False)
        for ax, t in zip(axes[0], targets):
            labels = [f"{r}/{s}" for r in rigs for s in sensors]
            x = np.arange(len(waters))
            wbar = 0.8 / max(1, len(labels))
            for i, lab in enumerate(labels):
                rig, s = lab.split("/", 1)
                vals, searched, ses = [], [], []
                for w in waters:
                    m = [v for v in vis if v["water"] == w and v["rig"] == rig and v["sensor"] == s
                         and v["target"] == t]
                    vals.append(m[0]["visibility_m_radiance"] if m and m[0]["visibility_m_radiance"] is not None
                                else np.nan)
                    searched.append(m[0].get("searched_to_m") or max(spec["distances_m"]) if m else np.nan)
                    se = m[0].get("visibility_m_radiance_se") if m else None
                    ses.append(se if se is not None else np.nan)
                vals, ses = np.array(vals, float), np.array(ses, float)
                err = np.where(np.isfinite(vals) & np.isfinite(ses), ses, 0.0)
                bars = ax.bar(x + i * wbar, np.where(np.isinf(vals), searched, vals), wbar, label=lab,
                              yerr=err if err.any() else None, capsize=2)
                for b, v in zip(bars, vals):
                    if np.isinf(v):
                        b.set_hatch("//")
            ax.set_xticks(x + 0.4 - wbar / 2, waters)
            ax.axhline(max(spec["distances_m"]), color="k", ls=":", lw=1)
            ax.set_ylabel("visibility range (m)")
            ax.set_title(t)
            ax.legend(fontsize=7)
        fig.tight_layout()
        sec.append(f"<h2>Visibility range</h2><img src='{_png(fig)}'>"
                   "<p>The dotted line is the sweep's largest distance.  Where a target was still visible there, "
                   "the study rendered it farther out with the fast engine (distance × 1.5 per step) until its "
                   "contrast fell below the threshold; a hatched bar means it was still visible at the farthest "
                   "distance tried.  Error bars and ± are one standard error from the fast engine's photon noise "
                   "(its multiply scattered light is traced with photons: the contrast of each independent batch "
                   "of them, at the two distances the range is interpolated between); they leave out the fast "
                   "engine's own error against Monte Carlo (the trust table) and the interpolation between "
                   "distances.</p>")
    # ------------------------------------------------------------------ image grids
    for rig in rigs:
        for s in sensors:
            for t in targets:
                cells = []
                for w in waters:
                    tr = [f"<th>{html.escape(w)}</th>"]
                    for dist in spec["distances_m"]:
                        m = [r for r in rows if r["rig"] == rig and r["sensor"] == s and r["water"] == w
                             and r["target"] == t and r["distance_m"] == dist]
                        img = d / "cases" / m[0]["case_id"] / f"{s}.png" if m else None
                        rel = f"cases/{m[0]['case_id']}/{s}.png" if m else ""
                        tr.append(f"<td><a href='{html.escape(rel)}'><img class='thumb' src='{_thumb(img)}'></a></td>"
                                  if img and img.is_file() else "<td>—</td>")
                    cells.append("<tr>" + "".join(tr) + "</tr>")
                head = "<tr><th></th>" + "".join(f"<th>{x:g} m</th>" for x in spec["distances_m"]) + "</tr>"
                sec.append(f"<h3>Images: {html.escape(rig)} · {html.escape(s)} · {html.escape(t)}</h3>"
                           f"<table class='grid'>{head}{''.join(cells)}</table>")
    if rows:
        sec.insert(len(sec) - len(rigs) * len(sensors) * len(targets),
                   f"<h2>Predicted photographs</h2><p>Each developed photograph is {int(spec['render']['width'])}×"
                   f"{int(spec['render']['height'])} pixels (click a thumbnail for the full-size file).</p>")
    sec += trust_section(d, agreement, spec)

    # ------------------------------------------------------------------ tables and inputs
    if vis:
        cols = list(vis[0].keys())
        trs = "".join("<tr>" + "".join(f"<td>{html.escape(_cell(v.get(c)))}</td>" for c in cols) + "</tr>"
                      for v in vis)
        sec.append("<h2>Visibility table</h2><table class='data'><tr>"
                   + "".join(f"<th>{html.escape(c)}</th>" for c in cols) + f"</tr>{trs}</table>")
    total_t = sum(t["wall_time_s"] or 0 for t in timings)
    r = spec["render"]
    spp_text = f"{r['spp']} samples per pixel"
    if r.get("noise_target"):
        used = sorted({int(x["spp"]) for x in rows if x.get("spp")})
        span = f"{used[0]}–{used[-1]}" if len(used) > 1 else (f"{used[0]}" if used else "?")
        spp_text = (f"{span} samples per pixel (batches of {r['spp']} until the Monte Carlo noise, 99th "
                    f"percentile of pixels in the noisiest colour, is below {r['noise_target']:g} of the local mean; at most "
                    f"{r.get('max_spp') or 8 * r['spp']}; column spp of results.csv)")
    if r["engine"] == "preview":
        spp_text = ("by the fast engine (rigsim.preview: semi-analytic, no Monte Carlo noise; checked against "
                    "Monte Carlo in the section above)")
    sec.append("<h2>Inputs</h2>"
               f"<p>Rendered at {r['width']}×{r['height']} pixels, {spp_text}, "
               f"{len(r['wavelengths_nm'])} bands {min(r['wavelengths_nm']):g}–{max(r['wavelengths_nm']):g} nm, "
               f"engine {html.escape(str(r['engine']))}; {len(timings)} scenes in {total_t:.0f} s of compute.</p>"
               f"<pre>{html.escape(json.dumps(spec, indent=1))}</pre>")

    page = f"""<!doctype html><html><head><meta charset="utf-8"><title>rigsim study: {html.escape(spec['name'])}</title>
<style>body{{font-family:sans-serif;margin:2em;max-width:1400px}} img{{max-width:100%}}
table.grid td,table.grid th{{padding:2px;text-align:center;font-size:12px}} img.thumb{{width:140px}}
table.data{{border-collapse:collapse;font-size:12px}} table.data td,table.data th{{border:1px solid #ccc;padding:2px 6px}}
pre{{background:#f5f5f5;padding:1em;font-size:11px;overflow:auto}}</style></head><body>
<h1>rigsim study: {html.escape(spec['name'])}</h1><p>{html.escape(spec.get('description', ''))}</p>
{''.join(sec)}</body></html>"""
    out = d / "report.html"
    atomic_write_text(out, page)
    return out


_REGION_KINDS = (("chart patches", lambda q, r: q == "radiance" and r.startswith("patch:")),
                 ("disk", lambda q, r: q == "radiance" and r == "disk"),
                 ("open water", lambda q, r: q == "radiance" and r == "open water"),
                 ("contrast", lambda q, r: q == "contrast_radiance"),
                 ("backscatter share", lambda q, r: q == "backscatter_share"),
                 ("speck share", lambda q, r: q == "speck_share"))


def _worst(rows: list[dict]) -> dict | None:
    """The row whose deviation is largest in magnitude."""
    rows = [r for r in rows if r.get("deviation") is not None and np.isfinite(r["deviation"])]
    return max(rows, key=lambda r: abs(r["deviation"])) if rows else None


def trust_sentences(agreement: list[dict], render: dict) -> list[str]:
    """One sentence on the fast engine's agreement with the Monte Carlo checks (fast-engine studies)."""
    if render.get("engine") != "preview":
        return []
    if not agreement:
        return ["The fast engine's numbers were not checked against Monte Carlo in this study "
                "(render.check_with_mitsuba = 0)."]
    from rigsim.metrics.agreement import MIN_CONTRAST, judged

    waters = list(dict.fromkeys(r["water"] for r in agreement))
    bad = [r for r in agreement if r["verdict"] == "disagrees" and r["quantity"] == "radiance"]
    n_cases = len({(r["rig"], r["water"], r["target"], r["distance_m"]) for r in agreement})
    w = _worst([r for r in agreement if r["quantity"] == "radiance" and judged(r)])
    if w is None:
        return [f"Fast engine against Monte Carlo in {n_cases} checked cases ({', '.join(waters)}): every chart "
                f"checked lies beyond its visibility (contrast below {MIN_CONTRAST:.0%} in both engines); nothing was judged."]
    txt = (f"Fast engine against Monte Carlo in {n_cases} checked cases ({', '.join(waters)}): the largest "
           f"region difference is {w['deviation']:+.1%} ± {w['deviation_se']:.1%} ({w['region']}, {w['group']}, "
           f"{w['water']} at {w['distance_m']:g} m)")
    if bad:
        bw = list(dict.fromkeys(r["water"] for r in bad))
        txt += (f"; {len(bad)} region values disagree beyond the tolerance and the two engines' noise, in "
                f"{', '.join(bw)} — read those waters' numbers with the table below in mind.")
    else:
        txt += "; every region agrees within its tolerance (3 % clear water, 5 % elsewhere) or the two engines' noise."
    return [txt]


def _cases_text(n: int) -> str:
    return "One chart case lit by strobes is" if n == 1 else f"{n} chart cases lit by strobes are"


def trust_section(d: Path, agreement: list[dict], spec: dict) -> list[str]:
    """"How far to trust these numbers": per water, the worst deviation of each kind of region and
    metric, and the checked cases' pictures side by side."""
    from rigsim.metrics.agreement import (BEYOND_VISIBILITY, HEAVY_TAIL, MIN_CONTRAST, case_key, heavy_tailed, judged,
                                         noise_multiplier, target_tails)

    if not agreement:
        return []
    waters = list(dict.fromkeys(r["water"] for r in agreement))
    tails = target_tails(agreement)
    head = ("<tr><th>water</th><th>cases checked (m)</th><th>tolerance</th>"
            + "".join(f"<th>{html.escape(k)}</th>" for k, _ in _REGION_KINDS) + "</tr>")
    trs = []
    for w in waters:
        rs = [r for r in agreement if r["water"] == w]
        dists = sorted({r["distance_m"] for r in rs})
        cells = []
        for _, sel in _REGION_KINDS:
            x = _worst([r for r in rs if sel(r["quantity"], r["region"]) and judged(r)])
            unseen = sorted({float(r["distance_m"]) for r in rs if sel(r["quantity"], r["region"]) and not judged(r)})
            at = (f"the chart at {', '.join(f'{d:g}' for d in unseen)} m is beyond its visibility: not judged"
                  if unseen else "")
            if x is None:
                cells.append(f"<td>— <small>({at})</small></td>" if unseen else "<td>—</td>")
                continue
            colour = {"agrees": "#dfd", "within noise": "#ffd", "disagrees": "#fdd"}.get(x["verdict"], "#fff")
            where = f"{x['region'].replace('patch:', '')}, {x['group']}, {x['distance_m']:g} m" + (f"; {at}" if at else "")
            if heavy_tailed(x.get("monte_carlo_tail")):
                where += f"; Monte Carlo heavy-tailed: one render {float(x['monte_carlo_tail']):.2g}× the median"
            elif x["region"] != "open water" and heavy_tailed(tails.get(case_key(x))):
                where += (f"; Monte Carlo heavy-tailed on this target (a region's render "
                          f"{tails[case_key(x)]:.2g}× the median)")
            cells.append(f"<td style='background:{colour}' title='{html.escape(where)}'>{x['deviation']:+.1%} "
                         f"± {x['deviation_se']:.1%}<br><small>{html.escape(where)}</small></td>")
        trs.append(f"<tr><td>{html.escape(w)}</td><td>{', '.join(f'{x:g}' for x in dists)}</td>"
                   f"<td>{rs[0]['tolerance']:.0%}</td>{''.join(cells)}</tr>")
    first = agreement[0]
    n_unseen = len({case_key(r) for r in agreement if not judged(r)})
    counts = sorted({int(r["seeds"]) for r in agreement if r.get("seeds")}) or [int(first["seeds"])]
    renders = (f"{counts[0]}" if len(counts) == 1 else
               f"{counts[0]}–{counts[-1]} (more where the first {counts[0]} left the reference noisy)")
    t_text = (f"{noise_multiplier(counts[0]):.2f} standard errors: Student's t for {counts[0]} renders"
              if len(counts) == 1 else f"Student's t for each case's renders: {noise_multiplier(counts[-1]):.2f}–"
              f"{noise_multiplier(counts[0]):.2f} standard errors")
    speck_n = sorted({int(r["seeds"]) for r in agreement if r.get("quantity") == "speck_share" and r.get("seeds")})
    speck_text = ("" if not speck_n else
                  f"; the speck share (marine snow) on the first "
                  f"{speck_n[0] if len(speck_n) == 1 else f'{speck_n[0]}–{speck_n[-1]}'} renders of each case, the "
                  f"ones also rendered without the particles (the particles' light is the difference)")
    out = [f"<h2>How far to trust these numbers</h2>"
           f"<p>Every photograph and number above comes from the fast engine.  {len({(r['rig'], r['water'], r['target'], r['distance_m']) for r in agreement})} "
           f"cases, chosen to cover the study's waters and distances, were also rendered by the Monte Carlo renderer "
           f"({renders} independent renders of {int(first['spp'])} paths per pixel at "
           f"{int(first['width'])}×{int(first['height'])} pixels).  Each cell is the largest difference, fast / Monte "
           f"Carlo − 1, over the checked cases' regions (each chart patch, the disk, the open water away from the "
           f"target; edge pixels left out) and colour groups (blue &lt; 490 nm, green 490–580, red ≥ 580), ± the "
           f"difference's standard error (the Monte Carlo reference's and the fast engine's own: its multiply "
           f"scattered light is traced with photons, and each batch of them makes its own image); green: within "
           f"the tolerance, yellow: within it plus the 95 % confidence half-width ({t_text}), red: beyond.  Contrast and backscatter share are the scene metrics of the tables "
           f"above, each measured on the mean of the Monte Carlo renders (a render's own noise would bias a "
           f"contrast upwards) with a jackknife standard error{speck_text}.  Where one Monte Carlo render of a region — or of another region of the same target — is "
           f"{HEAVY_TAIL:g} or more times the median render, the cell says so: there the reference itself is not "
           f"converged (rare paths carry much of the light; renders that missed them read low with a small "
           f"spread, so its standard error understates its error).  Every value is in agreement.csv "
           f"(monte_carlo_se, fast_se: the two standard errors; monte_carlo_tail: the largest render over the "
           f"median).</p>"
           + (f"<p>{n_unseen} chart case{'s' if n_unseen > 1 else ''} lie{'' if n_unseen > 1 else 's'} beyond the "
              f"chart's visibility: its white-against-black contrast is below {MIN_CONTRAST:.0%} in both engines (the "
              f"fast engine's by two standard errors, Monte Carlo's within its 95 % interval).  There a patch is only "
              f"the veil in front of it; its cells are listed in agreement.csv (verdict \"{BEYOND_VISIBILITY}\") but "
              f"not judged, and the table's patch column leaves them out.</p>" if n_unseen else "")
           + (f"<p>{_cases_text(len({(r['rig'], r['water'], r['target'], r['distance_m']) for r in agreement if r.get('reference') == 'hybrid'}))} "
              f"referenced by the hybrid estimate instead of plain renders: each reference image "
              f"is the renders' veil (the light that met no surface) plus the chart's light traced from the rig's lights "
              f"and seen "
              f"through the water by a camera pass (reference = \"hybrid\" in agreement.csv; rigsim.render.hybrid) — in "
              f"turbid water the renders' chart patches are heavy-tailed, the traced light is not.</p>"
              if any(r.get("reference") == "hybrid" for r in agreement) else "")
           + f"<table class='data'>{head}{''.join(trs)}</table>"]
    pics = []
    for case_dir in sorted((d / "checks").glob("*/check.json")):
        rec = json.loads(case_dir.read_text())
        f, m = case_dir.parent / "fast.png", case_dir.parent / "monte-carlo.png"
        if f.is_file() and m.is_file():
            pics.append(f"<figure style='display:inline-block;margin:4px'><img class='thumb' src='{_img_file(f)}'>"
                        f"<img class='thumb' src='{_img_file(m)}'><figcaption><small>{html.escape(rec['rig'])}, "
                        f"{html.escape(rec['water'])}, {html.escape(str(rec['target']))}, {rec['distance_m']:g} m: "
                        f"fast | Monte Carlo</small></figcaption></figure>")
    if pics:
        out.append("<h3>The checked cases: fast engine | Monte Carlo (same exposure)</h3>" + "".join(pics))
    return out


def _cell(v) -> str:
    if isinstance(v, float):
        return "inf" if np.isinf(v) else f"{v:.3g}"
    return "" if v is None else str(v)
