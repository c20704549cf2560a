"""Fast-engine studies: the Monte Carlo checks (which cases, what they measure, the report's trust
table) and the visibility range found beyond the sweep."""

import csv
import json
import math
from pathlib import Path

import numpy as np
import pytest

from rigsim.errors import ConfigError
from rigsim.study import load_study, run_study
from rigsim.study.spec import Case, select_check_cases

ROOT = Path(__file__).resolve().parents[2]

FAST = """
[study]
name = "fast"
seed = 2

[sweep]
rigs = ["{root}/rigs/twin-strobes-close-to-port.toml"]
sensors = ["sony_ilce-7rm2"]
waters = {waters}
distances_m = {distances}
targets = {targets}
target_fill = 0.4
{sweep_extra}

[render]
engine = "fast"
width = 64
height = 43
wavelengths = "420:680:40"
{render_extra}
"""


def fast_study(tmp_path, *, waters='["clear"]', distances="[1.0, 2.0]", targets='["black-disk"]', sweep_extra="",
               render_extra="", extra=""):
    p = tmp_path / "fast.toml"
    p.write_text(FAST.format(root=ROOT, waters=waters, distances=distances, targets=targets,
                             sweep_extra=sweep_extra, render_extra=render_extra) + extra)
    return p


def _cases(waters, dists, rigs=("a",), targets=("chart",)):
    return [Case(r, r, w, w, d, t, None) for r in rigs for w in waters for t in targets for d in dists]


def test_check_cases_cover_every_water_and_both_ends_of_the_distances():
    cases = _cases(["w1", "w2", "w3", "w4"], [1.0, 1.5, 2.0, 3.0, 4.5, 6.0], rigs=("r1", "r2"),
                   targets=("chart", "disk"))
    picked = select_check_cases(cases, 8)
    assert len(picked) == 8 and len(set(picked)) == 8
    for w in ("w1", "w2", "w3", "w4"):
        ds = sorted(c.distance_m for c in picked if c.water == w)
        assert ds == [1.0, 6.0], (w, ds)  # two per water: the nearest and the farthest
    assert {c.rig for c in picked} == {"r1", "r2"} and {c.target for c in picked} == {"chart", "disk"}
    assert picked == sorted(picked, key=cases.index)  # in sweep order
    three = select_check_cases(_cases(["w"], [1.0, 2.0, 3.0, 4.0, 5.0]), 3)
    assert [c.distance_m for c in three] == [1.0, 3.0, 5.0]
    assert select_check_cases(cases, 0) == [] and select_check_cases(cases[:3], 10) == cases[:3]
    assert len({c.water for c in select_check_cases(cases, 3)}) == 3  # fewer checks than waters: one each


def test_check_with_mitsuba_needs_the_fast_engine(tmp_path):
    p = fast_study(tmp_path, render_extra="check_with_mitsuba = 2")
    spec = load_study(p)
    assert spec.render.engine == "preview"  # "fast" is the fast engine's other name
    assert len(spec.check_cases()) == 2
    p.write_text(p.read_text().replace('engine = "fast"', 'engine = "mitsuba"'))
    with pytest.raises(ConfigError, match=r"render.check_with_mitsuba: .*needs engine = \"fast\""):
        load_study(p)
    q = fast_study(tmp_path, extra="\n[check]\nseeds = 1\n")
    with pytest.raises(ConfigError, match=r"check.seeds"):
        load_study(q)


def test_two_stage_checks_take_more_renders_only_where_the_first_are_too_noisy(tmp_path):
    """[check] max_seeds: the pilot's regions' relative SE (90th percentile) s sets the renders in all,
    ceil(seeds (s / target_se)^2) between seeds and max_seeds; the record says how many and the pilot's s.
    A reference that is noisy at 4 paths per pixel gets all 5; asked for 100 % it keeps the pilot's 2."""
    from rigsim.study.case import compute_check
    from rigsim.study.spec import CheckSettings

    ck = CheckSettings(seeds=4, max_seeds=16, target_se=0.015)
    assert [ck.renders_for(s) for s in (0.005, 0.015, 0.02, 0.03, 0.2, float("nan"))] == [4, 4, 8, 16, 16, 16]
    assert CheckSettings(seeds=4).renders_for(0.5) == 4  # (no max_seeds: one stage)
    with pytest.raises(ConfigError, match=r"check.max_seeds: max_seeds 2 is below seeds 4"):
        load_study(fast_study(tmp_path, extra="\n[check]\nseeds = 4\nmax_seeds = 2\n"))
    for target, want in ((1e-4, 5), (1.0, 2)):
        spec = load_study(fast_study(tmp_path, waters='["coastal"]', distances="[1.5]", render_extra="check_with_mitsuba = 1",
                                     extra=f"\n[check]\nwidth = 24\nheight = 16\nspp = 4\nseeds = 2\nmax_seeds = 5\n"
                                           f"target_se = {target}\n"))
        rec = compute_check(spec, spec.check_cases()[0])["record"]
        assert rec["seeds"] == want and rec["pilot"]["seeds"] == 2 and rec["pilot"]["se_p90"] > 0


def test_a_marine_snow_check_renders_the_particles_light_for_its_pilot_alone(tmp_path):
    """With marine snow, the renders a two-stage check takes beyond its pilot skip the particle-free pass: the kept
    renders beyond the pilot carry no particles' layer, the record says how many do, and the speck share's row is
    judged on that many renders (its Student's t)."""
    from rigsim.study.case import cached_render_dir, compute_check
    from rigsim.study.runner import agreement_rows

    snow = ROOT / "studies" / "waters" / "coastal-marine-snow.toml"
    spec = load_study(fast_study(tmp_path, waters=f'["{snow}"]', distances="[1.5]", render_extra="check_with_mitsuba = 1",
                                 extra="\n[check]\nwidth = 24\nheight = 16\nspp = 4\nseeds = 2\nmax_seeds = 3\n"
                                       "target_se = 0.0001\n"))
    case = spec.check_cases()[0]
    rec = compute_check(spec, case, render_cache=tmp_path / "mc")["record"]
    assert rec["seeds"] == 3 and rec["particle_renders"] == 2
    kept = cached_render_dir(tmp_path / "mc", spec, case)
    layers = [json.loads((kept / f"render-{i:03d}" / "meta.json").read_text())["layers"] for i in range(3)]
    assert ["flash_particles" in x for x in layers] == [True, True, False]
    speck = [r for r in agreement_rows([rec]) if r["quantity"] == "speck_share"]
    assert len(speck) == 1 and speck[0]["seeds"] == 2
    assert {r["seeds"] for r in agreement_rows([rec]) if r["quantity"] != "speck_share"} == {3}


def test_a_chart_beyond_its_visibility_takes_no_more_renders_for_its_patches(tmp_path):
    """A chart in Jerlov 9C at 6 m cannot be seen (its contrast far below 1 % in both engines): its patches are
    listed, not judged (verdict "beyond visibility"), and the two-stage reference sizes itself on the regions that
    are judged — the open water — not on the patches' noise."""
    from rigsim.metrics.agreement import BEYOND_VISIBILITY, relative_se
    from rigsim.study.case import compute_check
    from rigsim.study.runner import agreement_rows

    spec = load_study(fast_study(tmp_path, waters='["jerlov-9C"]', distances="[6.0]", targets='["colorchecker"]',
                                 render_extra='check_with_mitsuba = 1\nmultiple_scattering = "off"',
                                 extra="\n[check]\nwidth = 24\nheight = 16\nspp = 4\nseeds = 2\nmax_seeds = 5\n"
                                       "target_se = 1.0\n"))
    # (multiple scattering off: at 24 x 16 its photon noise alone would leave the fast contrast's 2-SE bound above 1 %)
    rec = compute_check(spec, spec.check_cases()[0])["record"]
    rows = agreement_rows([rec])
    patches = [r for r in rows if r["region"].startswith("patch:")]
    assert patches and {r["verdict"] for r in patches} == {BEYOND_VISIBILITY}
    assert {r["verdict"] for r in rows if r["region"] == "open water"} <= {"agrees", "within noise", "disagrees"}
    judged = [relative_se(r["reference"], r["reference_se"]) for r in rec["regions"] if not r["region"].startswith("patch:")]
    every = [relative_se(r["reference"], r["reference_se"]) for r in rec["regions"]]
    assert rec["seeds"] == 2 and rec["pilot"]["se_p90"] == pytest.approx(float(np.percentile(judged, 90)))
    assert float(np.percentile(every, 90)) > rec["pilot"]["se_p90"]  # the patches' noise would have asked for more


def test_hybrid_max_seeds_caps_the_hybrid_cases_alone(tmp_path):
    """[check] hybrid_max_seeds: the cases referenced by hybrid images take at most that many, every other case
    keeps max_seeds (a black disk in a hybrid study is referenced by renders: with a target SE it cannot reach it
    takes all max_seeds, not the hybrid cap); below seeds it is refused with the field named."""
    from rigsim.study.case import compute_check
    from rigsim.study.spec import CheckSettings

    ck = CheckSettings(seeds=4, max_seeds=32, target_se=0.015, hybrid_max_seeds=8)
    assert [ck.renders_for(s) for s in (0.015, 0.02, 0.2)] == [4, 8, 32]
    assert [ck.renders_for(s, hybrid=True) for s in (0.015, 0.02, 0.2)] == [4, 8, 8]
    assert CheckSettings(seeds=4, max_seeds=32).renders_for(0.2, hybrid=True) == 32  # no cap: max_seeds for all
    with pytest.raises(ConfigError, match=r"check.hybrid_max_seeds: hybrid_max_seeds 2 is below seeds 4"):
        load_study(fast_study(tmp_path, extra="\n[check]\nseeds = 4\nmax_seeds = 8\nhybrid_max_seeds = 2\n"))
    spec = load_study(fast_study(tmp_path, waters='["coastal"]', distances="[1.5]", render_extra="check_with_mitsuba = 1",
                                 extra='\n[check]\nwidth = 24\nheight = 16\nspp = 4\nseeds = 2\nmax_seeds = 5\n'
                                       'target_se = 1e-4\nreference = "hybrid"\nhybrid_max_seeds = 2\n'))
    rec = compute_check(spec, spec.check_cases()[0])["record"]
    assert rec["target"] == "black-disk" and rec["reference"] == "monte-carlo" and rec["seeds"] == 5


def test_a_checks_monte_carlo_renders_are_kept_and_only_the_missing_ones_rendered_again(tmp_path, monkeypatch):
    """With a render cache a check renders each of its Monte Carlo images once: the same check again renders
    nothing and gives the same record; asked for more renders (max_seeds) it renders only the new ones; a
    damaged file is rendered again.  Without the cache every render is made."""
    import rigsim.render as rr
    from rigsim.study.case import cached_render_dir, compute_check

    calls = []
    real = rr.render

    def counting(*a, **k):
        calls.append(k["seed"])
        return real(*a, **k)

    monkeypatch.setattr(rr, "render", counting)
    extra = "\n[check]\nwidth = 16\nheight = 12\nspp = 2\nseeds = 2\n"
    spec = load_study(fast_study(tmp_path, waters='["coastal"]', distances="[1.5]", render_extra="check_with_mitsuba = 1",
                                 extra=extra))
    case = spec.check_cases()[0]
    cache = tmp_path / "mc"
    first = compute_check(spec, case, render_cache=cache)["record"]
    assert len(calls) == 2 and len(list(cached_render_dir(cache, spec, case).glob("render-*/spectral.npz"))) == 2
    again = compute_check(spec, case, render_cache=cache)["record"]
    assert len(calls) == 2, "a kept render was made again"
    assert [r["reference"] for r in again["regions"]] == [r["reference"] for r in first["regions"]]
    more = load_study(fast_study(tmp_path, waters='["coastal"]', distances="[1.5]", render_extra="check_with_mitsuba = 1",
                                 extra=extra + "max_seeds = 3\ntarget_se = 1e-6\n"))
    assert more.check_id(case) != spec.check_id(case)
    assert compute_check(more, more.check_cases()[0], render_cache=cache)["record"]["seeds"] == 3
    assert len(calls) == 3, "only the third render is new"
    f = cached_render_dir(cache, spec, case) / "render-000" / "spectral.npz"
    f.write_bytes(f.read_bytes()[:100])  # truncated (a full disk, a kill outside the atomic write)
    assert compute_check(spec, case, render_cache=cache)["record"]["seeds"] == 2
    assert len(calls) == 4 and calls[-1] == calls[0]  # the damaged one again, with its own seed
    compute_check(spec, case)
    assert len(calls) == 6
    # the same study in another checkout (its rig file elsewhere, same contents) finds the same renders;
    # another rig does not
    other = tmp_path / "elsewhere"
    (other / "rigs").mkdir(parents=True)
    rig = ROOT / "rigs" / "twin-strobes-close-to-port.toml"
    (other / "rigs" / rig.name).write_bytes(rig.read_bytes())
    text = (tmp_path / "fast.toml").read_text().replace(str(ROOT / "rigs"), str(other / "rigs"))
    (tmp_path / "fast.toml").write_text(text)
    moved = load_study(tmp_path / "fast.toml")
    assert moved.case_id(moved.check_cases()[0]) != spec.case_id(case)
    assert cached_render_dir(cache, moved, moved.check_cases()[0]) == cached_render_dir(cache, spec, case)
    (other / "rigs" / rig.name).write_text(rig.read_text() + "\n# another rig file (a comment: its contents differ)\n")
    changed = load_study(tmp_path / "fast.toml")
    assert cached_render_dir(cache, changed, changed.check_cases()[0]) != cached_render_dir(cache, spec, case)
    # renders drawn by another sampler (the integrator's default options) are not the same renders
    import rigsim.render.integrators.strobe as strobe

    monkeypatch.setattr(strobe, "DEFAULT_LIGHT_DIRECTED_DEEP", strobe.DEFAULT_LIGHT_DIRECTED_DEEP / 2)
    assert cached_render_dir(cache, spec, case) != f.parent.parent


def _rows(path: Path) -> list[dict]:
    with path.open() as fh:
        return list(csv.DictReader(fh))


def test_visibility_is_found_beyond_the_sweep(tmp_path):
    """Clear water, a black disk: still visible at the sweep's 2 m, so the study goes on with the fast
    engine (x 1.5 per step) until the contrast is below the threshold, and the range is a number."""
    spec = load_study(fast_study(tmp_path))
    out = run_study(spec, tmp_path / "out", serial=True, progress=False)
    rows = _rows(out / "results.csv")
    ext = [r for r in rows if r["extension"] == "True"]
    assert ext, "nothing was rendered beyond the sweep"
    dists = [float(r["distance_m"]) for r in ext]
    assert dists == [round(2.0 * 1.5 ** k, 6) for k in range(1, len(dists) + 1)]
    last = ext[-1]
    assert float(last["contrast_radiance"]) < 0.02 and float(last["contrast_image"]) < 0.02
    before = [r for r in rows if float(r["distance_m"]) == (dists[-2] if len(dists) > 1 else 2.0)][0]
    assert max(float(before["contrast_radiance"]), float(before["contrast_image"])) >= 0.02
    (vis,) = _rows(out / "visibility.csv")
    v = float(vis["visibility_m_radiance"])
    assert 2.0 < v <= dists[-1] and math.isfinite(v)
    assert float(vis["sweep_max_m"]) == 2.0 and float(vis["searched_to_m"]) == dists[-1]
    # the range found by the fast engine carries its photons' noise (here 0.04 m: the clear water's class-B
    # light is a small part of the disk's surround)
    assert 0.0 < float(vis["visibility_m_radiance_se"]) < 0.05 * v
    # a second run replays the steps from the stored cases: nothing new, the same tables
    table = (out / "results.csv").read_text()
    n_cases = len(list((out / "cases").glob("*/result.json")))
    run_study(spec, out, serial=True, progress=False)
    assert (out / "results.csv").read_text() == table
    assert len(list((out / "cases").glob("*/result.json"))) == n_cases
    from rigsim.report.html import write_report

    page = write_report(out).read_text()
    assert "found beyond the sweep by the fast engine" in page


def test_the_visibility_range_carries_the_fast_engines_photon_noise(tmp_path):
    """Jerlov 3C, strobes by the port, a black disk: its contrast falls below 2 % between 1.5 and 3 m.  The
    multiply scattered light is traced with photons, so each case near the threshold gets the contrast's
    standard error from the photon batches (rigsim.study.case.contrast_photon_noise), the visibility table
    the range's (rigsim.metrics.visibility.visibility_range_se), and the report shows it."""
    from rigsim.metrics.visibility import visibility_range_se
    from rigsim.report.html import write_report

    p = fast_study(tmp_path, waters='["jerlov-3C"]', distances="[1.5, 3.0]", sweep_extra="extend_visibility = false")
    out = run_study(load_study(p), tmp_path / "out", serial=True, progress=False)
    rows = sorted(_rows(out / "results.csv"), key=lambda r: float(r["distance_m"]))
    assert all(int(r["ms_photons"]) > 0 for r in rows)
    c = np.array([float(r["contrast_radiance"]) for r in rows])
    se = np.array([float(r["contrast_radiance_se"]) for r in rows])
    # (measured 0.0012 and 0.0018 against contrasts of 0.069 and 0.013: the photons' batches are heavy-tailed,
    # so the bound is loose)
    assert c[0] >= 0.02 > c[1] and np.all(se > 0) and np.all(se < c), (c, se)
    (vis,) = _rows(out / "visibility.csv")
    v, v_se = float(vis["visibility_m_radiance"]), float(vis["visibility_m_radiance_se"])
    assert 1.5 < v < 3.0 and v_se == pytest.approx(visibility_range_se([1.5, 3.0], c, se), rel=1e-9)
    # the report gives the ± where it shows in the decimetres it prints (here 0.09 m)
    assert (f"{v:.1f} ± {v_se:.1f} m" if v_se >= 0.05 else f"to {v:.1f} m") in write_report(out).read_text()


def test_no_extension_when_asked_not_to(tmp_path):
    spec = load_study(fast_study(tmp_path, sweep_extra="extend_visibility = false"))
    out = run_study(spec, tmp_path / "out", serial=True, progress=False)
    assert all(r["extension"] == "False" for r in _rows(out / "results.csv"))
    (vis,) = _rows(out / "visibility.csv")
    assert math.isinf(float(vis["visibility_m_radiance"]))


@pytest.mark.render
def test_a_fast_study_checks_itself_against_monte_carlo(tmp_path):
    """One checked case in turbid Jerlov 3C water: agreement.csv has every region and colour group,
    the fast engine's open-water veil is within 15 % of Monte Carlo at this tiny size, and the report
    has the trust table and the side-by-side pictures."""
    p = fast_study(tmp_path, waters='["jerlov-3C"]', distances="[1.5]", targets='["colorchecker"]',
                   sweep_extra="extend_visibility = false", render_extra="check_with_mitsuba = 1",
                   extra="\n[check]\nwidth = 72\nheight = 48\nspp = 16\nseeds = 2\nmax_seeds = 3\ntarget_se = 0.0001\n"
                         "fast_noise_seeds = 1\n")
    spec = load_study(p)
    out = run_study(spec, tmp_path / "out", serial=True, progress=False)
    rows = _rows(out / "agreement.csv")
    assert {r["seeds"] for r in rows} == {"3"}  # (two stages: no pilot reaches 0.01 % standard error)
    regions = {r["region"] for r in rows if r["quantity"] == "radiance"}
    assert "open water" in regions and sum(x.startswith("patch:") for x in regions) >= 20
    assert {r["group"] for r in rows if r["quantity"] == "radiance"} == {"blue", "green", "red"}
    assert {r["quantity"] for r in rows} >= {"radiance", "contrast_radiance", "backscatter_share"}
    for r in rows:
        assert np.isfinite(float(r["deviation"])) and float(r["monte_carlo_se"]) >= 0
        assert r["verdict"] in ("agrees", "within noise", "disagrees")
        # the difference's standard error holds both engines' noise (the fast engine's from its photon batches)
        ref = abs(float(r["monte_carlo"]))
        assert float(r["deviation_se"]) == pytest.approx(
            math.hypot(float(r["monte_carlo_se"]), float(r["fast_se"])) / ref, rel=1e-6)
    assert any(float(r["fast_se"]) > 0 for r in rows if r["region"] == "open water")  # Jerlov 3C: traced
    veil = [float(r["deviation"]) for r in rows if r["region"] == "open water"]
    assert max(abs(v) for v in veil) < 0.15, veil
    (check_dir,) = (out / "checks").iterdir()
    assert (check_dir / "fast.png").is_file() and (check_dir / "monte-carlo.png").is_file()
    # the fast engine's noise from its own photon batches and one further render's (fast_noise_seeds = 1)
    assert json.loads((check_dir / "check.json").read_text())["fast_noise_renders"] == 2
    from rigsim.report.html import write_report

    page = write_report(out).read_text()
    assert "How far to trust these numbers" in page and "Fast engine against Monte Carlo in 1 checked" in page
    assert "(3 independent renders of 16 paths per pixel" in page and "Student's t for 3 renders" in page
    # resumed: the check is not rendered again
    before = (check_dir / "check.json").stat().st_mtime_ns
    run_study(spec, out, serial=True, progress=False)
    assert (check_dir / "check.json").stat().st_mtime_ns == before


def test_a_contrast_that_levels_off_is_not_a_visibility(tmp_path):
    """Edge-lit black disk in Jerlov 3C: against the ring of water around it the disk keeps a few
    percent of contrast however far it is (the strobes' veil differs between the two), so the steps
    beyond the sweep stop when the contrast stops falling, and the report says the range was not found.
    (With the multiply scattered light the contrast is 1.5 % at 3 m and 4.5 % at 6 m, where Monte
    Carlo has 4.8 ± 0.4 % and below 1 % at 3 m: it passes through zero between them.)"""
    from rigsim.study.runner import LEVEL_OFF

    p = fast_study(tmp_path, waters='["jerlov-3C"]', distances="[3.0, 6.0]")
    p.write_text(p.read_text().replace("twin-strobes-close-to-port", "twin-strobes-edge-lighting"))
    spec = load_study(p)
    out = run_study(spec, tmp_path / "out", serial=True, progress=False)
    rows = _rows(out / "results.csv")
    ext = [r for r in rows if r["extension"] == "True"]
    # stopped early (the cap is 12 steps), by the level-off rule: the rule looks at the sweep's last
    # distance and the steps beyond it, so it can stop after two steps (9 and 13.5 m on one machine,
    # 20.25 m on another: the photons' last bits differ between CPUs and the contrasts are within 3 %)
    assert 2 <= len(ext) < 12, [r["distance_m"] for r in ext]
    last_sweep = [r for r in rows if r["extension"] == "False" and float(r["distance_m"]) == 6.0]
    c = [max(float(r["contrast_radiance"]), float(r["contrast_image"])) for r in last_sweep + ext]
    assert c[-1] >= 0.02 and c[-1] >= LEVEL_OFF * c[-3]  # still visible, not falling: the rule, not the threshold
    assert all(c[i] < LEVEL_OFF * c[i - 2] for i in range(2, len(c) - 1))  # and not earlier
    (vis,) = _rows(out / "visibility.csv")
    assert not math.isfinite(float(vis["visibility_m_radiance"]))
    from rigsim.report.html import write_report

    assert "not found: the contrast levels off" in write_report(out).read_text()


def test_multiple_scattering_is_a_render_option_of_fast_studies(tmp_path):
    """``[render] multiple_scattering = "off" | "on" | "auto"`` reaches the fast engine ("auto" by default)."""
    from rigsim.errors import ConfigError
    from rigsim.study.case import compute_case

    auto = load_study(fast_study(tmp_path, waters='["jerlov-3C"]', distances="[1.0]"))
    assert auto.render.multiple_scattering == "auto" and auto.render.preview_multiple == "auto"
    p = fast_study(tmp_path, waters='["jerlov-3C"]', distances="[1.0]", render_extra='multiple_scattering = "off"')
    off = load_study(p)
    assert off.render.preview_multiple is False
    (case,) = [c for c in auto.cases() if not c.extension]
    rows_off = compute_case(off, case)["rows"]
    rows_auto = compute_case(auto, case)["rows"]
    # Jerlov 3C scatters widely: the multiply scattered veil raises the disk's surround
    assert rows_auto[0]["backscatter_share"] > rows_off[0]["backscatter_share"]
    bad = fast_study(tmp_path, render_extra='multiple_scattering = "yes"')
    with pytest.raises(ConfigError) as e:
        load_study(bad)
    assert "render.multiple_scattering" in str(e.value) and "\n" not in str(e.value)


def test_a_hybrid_check_chooses_its_renders_veil_per_image_from_its_pilot(tmp_path, monkeypatch):
    """[check] hybrid_veil_max_renders: after the pilot (2 images of 2 renders' veil) the count is chosen from the
    split of the pilot's noise into one render's veil and one camera pass's light (relative variances of the
    judged regions, finite, the veil's not all zero) and the renders' and passes' costs (their times); every image
    is then made again of that many renders, the pilot's among them, no camera pass twice; the record says how
    many.  Run again choosing the pilot's count, it keeps the pilot's images (other references, nothing made)."""
    import rigsim.render.hybrid as hy
    from rigsim.study.case import cached_render_dir, compute_check

    seen = {}

    def choose(v, p, *, render_s, pass_s, k_min, k_max):
        seen.update(v=np.asarray(v, float), p=np.asarray(p, float), render_s=render_s, pass_s=pass_s,
                    k_min=k_min, k_max=k_max)
        return k_max

    monkeypatch.setattr(hy, "veil_renders_for", choose)
    passes = []
    real = hy.hybrid_reflected
    monkeypatch.setattr(hy, "hybrid_reflected", lambda *a, **k: passes.append(k["seed"]) or real(*a, **k))
    extra = ("\n[check]\nwidth = 24\nheight = 16\nspp = 2\nseeds = 2\nreference = \"hybrid\"\n"
             "hybrid_photons = 20000\nhybrid_spp = 1\nhybrid_veil_renders = 2\nhybrid_veil_max_renders = 3\n")
    spec = load_study(fast_study(tmp_path, waters='["coastal"]', distances="[1.5]", targets='["colorchecker"]',
                                 render_extra="check_with_mitsuba = 1", extra=extra))
    case = spec.check_cases()[0]
    cache = tmp_path / "mc"
    rec = compute_check(spec, case, render_cache=cache)["record"]
    assert seen["k_min"] == 2 and seen["k_max"] == 3 and seen["render_s"] > 0 and seen["pass_s"] > 0
    assert seen["v"].shape == seen["p"].shape and seen["v"].size >= 24 * 3  # the patches x colour groups at least
    assert np.all(np.isfinite(seen["v"])) and np.all(np.isfinite(seen["p"])) and seen["v"].max() > 0
    assert rec["hybrid"]["veil_renders"] == 3 and rec["pilot"]["veil_renders_chosen"] == 3
    assert rec["pilot"]["veil_renders"] == 2 and np.isfinite(rec["pilot"]["se_p90_predicted"])
    n = rec["seeds"]
    assert len(list(cached_render_dir(cache, spec, case).glob("render-*/spectral.npz"))) == 3 * n
    assert len(passes) == n == len(set(passes))
    with np.load(sorted(cached_render_dir(cache, spec, case).glob("hybrid-*.npz"))[0]) as z:
        assert float(z["seconds"]) > 0  # the pass's time is kept for the next run's choice
    monkeypatch.setattr(hy, "veil_renders_for", lambda v, p, **k: k["k_min"])
    rec2 = compute_check(spec, case, render_cache=cache)["record"]  # the kept renders and passes: nothing new
    assert rec2["hybrid"]["veil_renders"] == 2 and rec2["pilot"]["veil_renders_chosen"] == 2
    assert len(passes) == n and len(list(cached_render_dir(cache, spec, case).glob("render-*"))) == 3 * n
    assert [r["reference"] for r in rec2["regions"]] != [r["reference"] for r in rec["regions"]]


def test_a_hybrid_check_references_the_chart_by_light_tracing_and_keeps_its_parts(tmp_path, monkeypatch):
    """[check] reference = "hybrid": a chart case's reference images are renders whose flash is their veil plus
    the chart's light by light tracing and a camera pass (rigsim.render.hybrid), each kept beside the renders
    and made once; the record says which reference it is; a disk case stays plain Monte Carlo."""
    import rigsim.render.hybrid as hy
    from rigsim.study.case import cached_render_dir, compute_check

    calls = []
    real = hy.hybrid_reflected

    def counting(*a, **k):
        calls.append(k["seed"])
        return real(*a, **k)

    monkeypatch.setattr(hy, "hybrid_reflected", counting)
    (tmp_path / "p").mkdir()
    (tmp_path / "d").mkdir()
    extra = ("\n[check]\nwidth = 24\nheight = 16\nspp = 2\nseeds = 2\nreference = \"hybrid\"\n"
             "hybrid_photons = 20000\nhybrid_spp = 1\nhybrid_veil_renders = 2\n")
    spec = load_study(fast_study(tmp_path, waters='["coastal"]', distances="[1.5]", targets='["colorchecker"]',
                                 render_extra="check_with_mitsuba = 1", extra=extra))
    plain = load_study(fast_study(tmp_path / "p", waters='["coastal"]', distances="[1.5]", targets='["colorchecker"]',
                                  render_extra="check_with_mitsuba = 1",
                                  extra=extra.replace('reference = "hybrid"', 'reference = "monte-carlo"')))
    case = spec.check_cases()[0]
    assert spec.check_id(case) != plain.check_id(plain.check_cases()[0])
    cache = tmp_path / "mc"
    rec = compute_check(spec, case, render_cache=cache)["record"]
    from rigsim.render.hybrid import DEFAULT_FIT_ORDER

    assert rec["reference"] == "hybrid" and rec["hybrid"] == {"photons": 20000, "spp": 1, "veil_renders": 2,
                                                              "veil_sigma_px": 4.0, "order": DEFAULT_FIT_ORDER}
    assert len(list(cached_render_dir(cache, spec, case).glob("render-*/spectral.npz"))) == 4  # 2 veils each
    assert len(calls) == 2 and len(set(calls)) == 2  # one independent estimate per reference image
    kept = sorted(cached_render_dir(cache, spec, case).glob("hybrid-*.npz"))
    assert len(kept) == 2
    again = compute_check(spec, case, render_cache=cache)["record"]
    assert len(calls) == 2, "a kept hybrid part was made again"
    assert [r["reference"] for r in again["regions"]] == [r["reference"] for r in rec["regions"]]
    # the same renders under the plain reference: the chart's patches differ (their light is replaced), the
    # open water away from the chart does not (its light is the renders' own veil)
    base = compute_check(plain, plain.check_cases()[0], render_cache=cache)["record"]
    assert base["reference"] == "monte-carlo"
    ref = {(r["region"], r["group"]): r["reference"] for r in rec["regions"]}
    ref0 = {(r["region"], r["group"]): r["reference"] for r in base["regions"]}
    assert any(abs(ref[k] / ref0[k] - 1) > 1e-3 for k in ref if k[0].startswith("patch:"))
    assert all(ref[k] == pytest.approx(ref0[k], rel=0.05) for k in ref if k[0] == "open water")
    disk = load_study(fast_study(tmp_path / "d", waters='["coastal"]', distances="[1.5]",
                                 render_extra="check_with_mitsuba = 1", extra=extra))
    assert compute_check(disk, disk.check_cases()[0])["record"]["reference"] == "monte-carlo"
    assert len(calls) == 2
