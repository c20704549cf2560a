"""The verdicts of the fast-engine checks (:mod:`rigsim.metrics.agreement`): a Z test of the difference."""

from __future__ import annotations

import gzip
from pathlib import Path

import numpy as np
import pytest

from rigsim.metrics.agreement import MetricDeviation, RegionDeviation, verdict


def _verdict(d) -> str:
    return verdict(d.deviation, d.deviation_se, 0.05)


def test_the_difference_is_judged_on_the_references_noise_whichever_side_the_fast_value_is():
    # Jerlov 3C, a chart at 6 m (demo, 2026-12-02): fast contrast 0.62 %, Monte Carlo 2.37 ± 1.10 %.
    # (fast − ref)/se = −1.6: inside the tolerance plus two standard errors.  The ratio's first-order
    # error, fast·se/ref², called it −74 ± 12 %: a disagreement.
    low = MetricDeviation("contrast_radiance", fast=0.0062, reference=0.0237, reference_se=0.0110)
    assert abs(low.deviation_se - 0.0110 / 0.0237) < 1e-12
    assert _verdict(low) == "within noise"
    # the same distance above the reference is judged the same way
    high = MetricDeviation("contrast_radiance", fast=0.0237 + (0.0237 - 0.0062), reference=0.0237, reference_se=0.0110)
    assert np.isclose(high.deviation_se, low.deviation_se) and _verdict(high) == "within noise"


def test_a_clear_difference_still_disagrees_and_a_small_one_agrees():
    far = RegionDeviation("open water", "blue", 100, fast=0.90, reference=1.0, reference_se=0.01)
    assert _verdict(far) == "disagrees"  # −10 % ± 1 %
    near = RegionDeviation("open water", "blue", 100, fast=0.97, reference=1.0, reference_se=0.01)
    assert _verdict(near) == "agrees"
    noisy = RegionDeviation("patch:white", "red", 9, fast=0.92, reference=1.0, reference_se=0.02)
    assert _verdict(noisy) == "within noise"  # −8 % ≤ 5 % + 2 × 2 %
    assert verdict(float("nan"), 0.1, 0.05) == "no reference"


def test_within_noise_is_the_95_percent_interval_of_the_seeds():
    """With the spread of n renders as the reference's standard error, "within noise" is the tolerance plus
    Student's t(0.975, n − 1) standard errors (3.18 for 4 renders, 2.36 for 8; 2 if n is unknown)."""
    from rigsim.metrics.agreement import noise_multiplier

    assert noise_multiplier(4) == pytest.approx(3.182, abs=1e-3)
    assert noise_multiplier(8) == pytest.approx(2.365, abs=1e-3)
    assert noise_multiplier(None) == 2.0 and noise_multiplier(1) == 2.0
    # −12 % ± 2.5 %: beyond 5 % + 2 SE, inside 5 % + 3.18 SE (4 renders), beyond 5 % + 2.36 SE (8 renders)
    assert verdict(-0.12, 0.025, 0.05) == "disagrees"
    assert verdict(-0.12, 0.025, 0.05, seeds=4) == "within noise"
    assert verdict(-0.12, 0.025, 0.05, seeds=8) == "disagrees"


def test_a_reference_with_one_render_far_above_the_rest_is_called_heavy_tailed():
    """The tail of each region value is the largest render's region mean over the median render's: near 1 for
    renders that scatter by a few per cent, the spike's factor when one render holds a rare large path (as
    Monte Carlo's chart patches in high-albedo water do); the verdict itself is unchanged by it."""
    from rigsim.metrics.agreement import HEAVY_TAIL, compare_renders, heavy_tailed
    from rigsim.spectral_image import SpectralImage

    rng = np.random.default_rng(4)
    wl = np.array([450.0, 550.0, 650.0])

    def img(level):
        return SpectralImage(radiance=np.full((30, 40, 3), level, np.float32), wavelength_nm=wl,
                             bandwidth_nm=np.full(3, 100.0), layers={"object_id": np.zeros((30, 40), np.int32)})

    fast = img(1.0)
    calm = [img(1.0 + 0.03 * rng.standard_normal()) for _ in range(8)]
    regions, _ = compare_renders(fast, calm, "colorchecker")
    assert [r.region for r in regions] == ["open water"] * 3
    assert all(1.0 <= r.reference_tail < 1.2 and not heavy_tailed(r.reference_tail) for r in regions)
    spiked = calm[:7] + [img(20.0)]
    regions, _ = compare_renders(fast, spiked, "colorchecker")
    for r in regions:
        assert r.reference_tail == pytest.approx(20.0 / np.median([c.radiance.mean() for c in spiked]), rel=1e-3)
        assert r.reference_tail >= HEAVY_TAIL and heavy_tailed(r.reference_tail)
        assert r.record()["reference_tail"] == r.reference_tail
    assert not heavy_tailed(None) and not heavy_tailed("") and not heavy_tailed(float("nan"))


def test_the_fast_engines_photon_noise_enters_the_differences_standard_error():
    """With the fast image's batch images (one per batch of its multiple-scattering photons) the fast value's
    standard error is their spread over √batches, and the difference's is both engines' together: a fast
    value 12 % below a reference of ±0.8 % disagrees alone (12 % > 5 % + 3.18 × 0.8 %), and is within noise
    once the fast engine's own ±2.4 % is counted (12 % ≤ 5 % + 3.18 × 2.6 %)."""
    from rigsim.metrics.agreement import compare_renders
    from rigsim.spectral_image import SpectralImage

    wl = np.array([450.0, 550.0, 650.0])

    def img(level):
        return SpectralImage(radiance=np.full((30, 40, 3), level, np.float32), wavelength_nm=wl,
                             bandwidth_nm=np.full(3, 100.0), layers={"object_id": np.zeros((30, 40), np.int32)})

    refs = [img(1.0 + d) for d in (-0.02, 0.0, 0.02, 0.0)]  # mean 1, SE 0.0082
    fast = img(0.88)
    batches = [img(0.88 + d) for d in (-0.06, 0.0, 0.06, 0.0)]  # mean 0.88, SE 0.0245
    alone = compare_renders(fast, refs, "colorchecker")[0][0]
    both = compare_renders(fast, refs, "colorchecker", fast_batches=batches)[0][0]
    se_ref, se_fast = np.std([-0.02, 0, 0.02, 0], ddof=1) / 2, np.std([-0.06, 0, 0.06, 0], ddof=1) / 2
    assert alone.fast_se == 0.0 and alone.deviation_se == pytest.approx(se_ref, rel=1e-5)
    assert both.fast_se == pytest.approx(se_fast, rel=1e-5)
    assert both.deviation_se == pytest.approx(np.hypot(se_ref, se_fast), rel=1e-5)
    assert verdict(alone.deviation, alone.deviation_se, 0.05, 4) == "disagrees"
    assert verdict(both.deviation, both.deviation_se, 0.05, 4) == "within noise"
    assert both.record()["fast_se"] == both.fast_se
    with pytest.raises(ValueError, match="differ in shape"):
        compare_renders(fast, refs, "colorchecker", fast_batches=[SpectralImage(
            radiance=np.ones((3, 4, 3), np.float32), wavelength_nm=wl, bandwidth_nm=np.full(3, 100.0),
            layers={"object_id": np.zeros((3, 4), np.int32)})])


def test_further_renders_batches_make_the_fast_engines_noise_estimate_steadier():
    """With the fast image's 4 batches alone each noise estimate has 3 degrees of freedom: its square scatters by
    √(2/3) = 82 % of the true variance; with 3 further renders' batches pooled (``noise_batches``), 12 degrees
    of freedom and √(2/12) = 41 %.  Simulated: a black disk in water, each batch image with independent pixel
    noise, the fast image their mean.  Over 300 cases the disk's and the contrast's squared standard errors
    average to the true variances of the fast values either way (the contrast's measured over the cases), and
    their spread halves."""
    from rigsim.metrics.agreement import compare_renders
    from rigsim.spectral_image import SpectralImage

    wl = np.array([450.0, 550.0, 650.0])
    rows, cols = 30, 40
    y, x = np.mgrid[0:rows, 0:cols]
    oid = (((y - 15) ** 2 + (x - 20) ** 2) <= 25).astype(np.int32)
    truth = np.where(oid == 1, 0.6, 1.0)[..., None] * np.ones(3)
    rng = np.random.default_rng(5)
    sigma = 0.3  # relative pixel noise of one batch image

    def img(a):
        return SpectralImage(radiance=a.astype(np.float32), wavelength_nm=wl, bandwidth_nm=np.full(3, 100.0),
                             layers={"object_id": oid}, meta={"object_ids": {"1": "disk"}})

    def batches():
        return [truth * (1 + sigma * rng.standard_normal((rows, cols, 1))) for _ in range(4)]

    refs = [img(truth * (1 + 0.01 * k)) for k in (-1, 0, 1, 0)]
    out = {0: [], 3: []}
    fast_values = []
    for _ in range(300):
        own = batches()
        fast = img(np.mean(own, axis=0))
        extra = [[img(b) for b in batches()] for _ in range(3)]
        for k in out:
            regions, metrics = compare_renders(fast, refs, "black-disk", fast_batches=[img(b) for b in own],
                                               noise_batches=extra[:k])
            disk = next(r for r in regions if r.region == "disk" and r.group == "green")
            contrast = next(m for m in metrics if m.metric == "contrast_radiance")
            out[k].append((disk.fast_se ** 2, contrast.fast_se ** 2))
        fast_values.append((disk.fast, contrast.fast))
    true_var = np.var(np.array(fast_values), axis=0, ddof=1)
    for k, dof in ((0, 3), (3, 12)):
        v = np.array(out[k])
        ratio = v / true_var
        assert np.all(np.abs(ratio.mean(axis=0) - 1) < 0.2), (k, ratio.mean(axis=0))
        spread = ratio.std(axis=0, ddof=1) / ratio.mean(axis=0)
        assert np.all(np.abs(spread / np.sqrt(2 / dof) - 1) < 0.3), (k, spread, np.sqrt(2 / dof))
    with pytest.raises(ValueError, match="as many batch images"):
        compare_renders(fast, refs, "black-disk", fast_batches=[img(b) for b in own], noise_batches=[extra[0][:3]])


def test_a_case_is_heavy_tailed_on_its_target_if_any_of_its_target_regions_is():
    """A patch whose renders all missed the rare paths reads low with a small tail; its case is flagged by
    the largest tail among the target's regions (the open water and scene metrics do not count)."""
    from rigsim.metrics.agreement import case_key, heavy_tailed, target_tails

    base = {"lighting": "strobes", "rig": "r", "water": "jerlov-9C", "target": "colorchecker", "distance_m": 1.0}
    rows = [{**base, "quantity": "radiance", "region": "patch:red", "monte_carlo_tail": 1.2},
            {**base, "quantity": "radiance", "region": "patch:yellow", "monte_carlo_tail": "56.7"},
            {**base, "quantity": "radiance", "region": "open water", "monte_carlo_tail": 80.0},
            {**base, "quantity": "contrast_radiance", "region": "target", "monte_carlo_tail": None},
            {**base, "distance_m": 3.0, "quantity": "radiance", "region": "patch:red", "monte_carlo_tail": 1.5},
            {**base, "distance_m": 3.0, "quantity": "radiance", "region": "open water", "monte_carlo_tail": 9.0}]
    tails = target_tails(rows)
    assert tails == {case_key(rows[0]): 56.7, case_key(rows[4]): 1.5}
    assert heavy_tailed(tails[case_key(rows[0])]) and not heavy_tailed(tails[case_key(rows[4])])


def test_a_contrast_is_measured_on_the_mean_of_the_renders_with_a_jackknife_error():
    """The Michelson contrast ``|L_t − L_b| / (L_t + L_b)`` of a render's own noisy means is biased upwards by
    the noise; averaging it over renders keeps the bias (Jerlov 9C, chart at 3 m: 0.125 where the renders'
    mean patches differ by 0.4 %).  A black disk 2 % darker than the water (contrast 0.0101) under pixel
    noise of 50 %: over 200 sets of 16 renders the pooled contrast (:func:`pooled_metric`) averages to the true
    one within 3 standard errors of that average (0.0109), its jackknife standard error matches the spread
    of the estimates between sets (ratio 0.8–1.25; 1.18, a little conservative so near zero), and the old
    average of each render's contrast is more than twice the truth (0.028)."""
    from rigsim.metrics.agreement import pooled_metric
    from rigsim.metrics.scene import scene_metrics, target_masks
    from rigsim.spectral_image import SpectralImage

    wl = np.array([450.0, 550.0, 650.0])
    rows, cols = 40, 60
    y, x = np.mgrid[0:rows, 0:cols]
    oid = (((y - 20) ** 2 + (x - 30) ** 2) <= 36).astype(np.int32)
    truth = np.where(oid == 1, 0.98, 1.0)[..., None] * np.ones(3)
    masks = target_masks(oid, {"1": "disk"}, "black-disk")
    true_c = 0.02 / 1.98
    rng = np.random.default_rng(11)

    def metric(si):
        return scene_metrics(si, "black-disk", masks=masks)[0]

    def render():
        return SpectralImage(radiance=truth * (1 + 0.5 * rng.standard_normal((rows, cols, 1))), wavelength_nm=wl,
                             bandwidth_nm=np.full(3, 100.0), layers={"object_id": oid}, meta={"object_ids": {"1": "disk"}})

    pooled, ses, averaged = [], [], []
    for _ in range(200):
        renders = [render() for _ in range(16)]
        v, se = pooled_metric(renders, metric)
        pooled.append(v["contrast_radiance"])
        ses.append(se["contrast_radiance"])
        averaged.append(np.mean([metric(r)["contrast_radiance"] for r in renders]))
    pooled = np.array(pooled)
    assert abs(pooled.mean() - true_c) < 3 * pooled.std(ddof=1) / np.sqrt(len(pooled)), (pooled.mean(), true_c)
    assert 0.8 < np.mean(ses) / pooled.std(ddof=1) < 1.25, (np.mean(ses), pooled.std(ddof=1))
    assert np.mean(averaged) > 2 * true_c, np.mean(averaged)


def test_a_speck_share_is_measured_on_the_renders_with_the_particles_light_alone():
    """With marine snow a check renders the particles' light (a second, particle-free pass) only for its pilot's
    renders (:func:`rigsim.study.case.compute_check`): the speck share is measured on those renders (their
    mean, jackknife SE), the regions and the contrast on all of them; a mean image of renders that do not all
    carry a layer leaves it out (not the first render's own); with fewer than two such renders the speck share
    is not compared."""
    from rigsim.metrics.agreement import compare_renders, mean_image, pooled_metric
    from rigsim.metrics.specks import has_particle_layer
    from rigsim.spectral_image import SpectralImage

    wl = np.array([450.0, 550.0, 650.0])
    rows, cols = 30, 40
    y, x = np.mgrid[0:rows, 0:cols]
    oid = ((np.abs(y - 15) <= 6) & (np.abs(x - 20) <= 8)).astype(np.int32)  # a white target
    pid = np.zeros((rows, cols), np.int32)
    pid[2:4, 2:4], pid[25:27, 33:35] = 1, 2  # two specks in the water
    rng = np.random.default_rng(3)

    def img(with_particles, level=1.0):
        base = np.where(oid == 1, 0.8, 0.2)[..., None] * np.ones(3) * level
        part = np.where(pid > 0, 0.3, 0.0)[..., None] * np.ones(3) * (1 + 0.3 * rng.standard_normal())
        layers = {"object_id": oid, "particle_id": pid}
        if with_particles:
            layers["particles"] = part.astype(np.float32)
        return SpectralImage(radiance=(base + part).astype(np.float32), wavelength_nm=wl,
                             bandwidth_nm=np.full(3, 100.0), layers=layers,
                             meta={"object_ids": {"1": "chart"}, "particles": {"count": 2}})

    fast = img(True)
    refs = [img(True, 1 + 0.01 * k) for k in range(3)] + [img(False, 1 - 0.01 * k) for k in range(3)]
    assert [has_particle_layer(r) for r in refs] == [True] * 3 + [False] * 3
    assert "particles" not in mean_image(refs).layers and "particles" in mean_image(refs[:3]).layers
    _, metrics = compare_renders(fast, refs, "white-disk")
    got = {m.metric: m for m in metrics}
    from rigsim.metrics.agreement import fast_estimates

    fn = fast_estimates(fast, "white-disk").radiance_metrics
    m3, se3 = pooled_metric(refs[:3], fn)
    m6, se6 = pooled_metric(refs, fn)
    assert got["speck_share"].reference == pytest.approx(m3["speck_share"])
    assert got["speck_share"].reference_se == pytest.approx(se3["speck_share"])
    # (measured on all six renders' mean, which has no particles' light, it would read 0)
    assert got["speck_share"].reference > 0 and not m6.get("speck_share")
    assert got["contrast_radiance"].reference == pytest.approx(m6["contrast_radiance"])
    assert got["contrast_radiance"].reference_se == pytest.approx(se6["contrast_radiance"])
    # one render with the particles' light: no speck share to compare
    _, metrics = compare_renders(fast, refs[2:], "white-disk")
    assert "speck_share" not in {m.metric for m in metrics} and "contrast_radiance" in {m.metric for m in metrics}


def _row(rig, water, region, dev, verdict="agrees", se=0.01, distance=1.0):
    return {"rig": rig, "water": water, "target": "black-disk", "distance_m": distance, "quantity": "radiance",
            "region": region, "group": "blue", "deviation": dev, "deviation_se": se, "tolerance": 0.05,
            "verdict": verdict, "lighting": "strobes"}


def test_the_published_table_keeps_each_rig_apart_and_a_rig_it_did_not_check_gets_the_cautious_row(tmp_path,
                                                                                                     monkeypatch):
    import rigsim.data
    from rigsim.metrics.agreement import PUBLISHED_TABLE, published_agreement, write_published

    monkeypatch.setattr(rigsim.data, "DATA_DIR", tmp_path)
    path = tmp_path / PUBLISHED_TABLE
    path.parent.mkdir(parents=True)
    # a table of the older layout (one row per water, summed over rigs): superseded, dropped on writing
    path.write_text("lighting,water,cases,distances_m,worst_deviation,worst_se,worst_where,tolerance,beyond,cells,"
                    "measured,settings\nstrobes,jerlov-9C,4,\"1, 3\",-0.15,0.16,old,0.05,0,162,2026-12-05,old\n")
    assert published_agreement("jerlov-9C") is None  # not read: its numbers are not any one rig's
    write_published([_row("wide", "jerlov-9C", "open water", -0.04), _row("wide", "jerlov-9C", "disk", 0.02),
                     _row("edge", "jerlov-9C", "open water", -0.095, "within noise", 0.028, 3.0)],
                    path, settings="test")
    write_published([_row("wide", "coastal", "disk", 0.01)], path, settings="test")  # another water: kept apart
    wide = published_agreement("jerlov-9C", rig="wide")
    edge = published_agreement("jerlov-9C", rig="edge")
    assert (wide.rig, wide.worst_deviation, wide.cases, wide.cells) == ("wide", -0.04, 1, 2)
    assert (edge.rig, edge.worst_deviation, edge.worst_se, edge.distances_m) == ("edge", -0.095, 0.028, "3")
    assert "edge" in edge.sentence("edge") and "not checked" not in edge.sentence("edge")
    # a rig the benchmark did not check: the row farthest from Monte Carlo, and the sentence says whose it is
    other = published_agreement("jerlov-9C", rig="my-own-rig")
    assert other.rig == "edge"
    assert "not checked with my-own-rig" in other.sentence("my-own-rig")
    assert published_agreement("coastal").rig == "wide"
    assert published_agreement("jerlov-3C") is None
    assert "old" not in path.read_text().split("\n", 3)[3]  # the older layout's row is gone
    # another set of distances for the same rig adds a row beside the first; the rig's answer is the worse of them
    write_published([_row("wide", "jerlov-9C", "disk", 0.07, "disagrees", distance=6.0)], path, settings="test")
    wide = published_agreement("jerlov-9C", rig="wide")
    assert (wide.worst_deviation, wide.distances_m, wide.beyond) == (0.07, "6", 1)
    # 6 m again: replaced
    write_published([_row("wide", "jerlov-9C", "disk", 0.01, distance=6.0)], path, settings="test")
    assert published_agreement("jerlov-9C", rig="wide").worst_deviation == -0.04  # the 1 m row is the worse now
    assert path.read_text().count("strobes,jerlov-9C,wide,") == 2
    # a run over 1 and 6 m (and 3) supersedes both: one row left, with all its distances
    write_published([_row("wide", "jerlov-9C", "disk", 0.02, distance=d) for d in (1.0, 3.0, 6.0)], path,
                    settings="test")
    assert path.read_text().count("strobes,jerlov-9C,wide,") == 1
    assert published_agreement("jerlov-9C", rig="wide").distances_m == "1, 3, 6"


def test_a_row_of_an_earlier_engine_goes_once_this_engines_rows_cover_its_distances(tmp_path):
    """``write_published(..., current=...)``: an earlier engine's row stays while only some of its distances are
    re-made (one run per distance), and goes with the run that brings its last; another stale row of the same rig
    is not dropped by the rows that cover the first, nor is a current row covered only in part."""
    from rigsim.metrics.agreement import read_published, write_published

    path = tmp_path / "agreement.csv"
    header = ("lighting,water,rig,cases,distances_m,worst_deviation,worst_se,worst_where,tolerance,beyond,cells,"
              "measured,engine,settings\n")
    old = lambda dist: f'strobes,jerlov-7C,wide,4,"{dist}",-0.2,0.1,x,0.05,0,100,2026-12-06,commit old,s\n'  # noqa: E731
    path.write_text(header + old("0.5, 1, 3, 6") + old("0.5, 6").replace(",wide,", ",edge,")
                    + old("1, 3").replace(",wide,", ",edge,"))
    is_new = lambda r: r["engine"] == "commit new"  # noqa: E731

    def publish(rig, *dists):
        write_published([_row(rig, "jerlov-7C", "disk", 0.01, distance=d) for d in dists], path, settings="t",
                        engine="commit new", current=is_new)
        return {(k[2], k[3]): r["engine"] for k, r in read_published(path).items()}

    assert publish("wide", 3.0)[("wide", "0.5, 1, 3, 6")] == "commit old"  # 0.5, 1 and 6 m still the old one's
    assert ("wide", "0.5, 1, 3, 6") in publish("wide", 0.5, 1.0)
    got = publish("wide", 6.0)
    assert ("wide", "0.5, 1, 3, 6") not in got  # its last distance re-made: gone
    assert {k for k, e in got.items() if k[0] == "wide"} == {("wide", "3"), ("wide", "0.5, 1"), ("wide", "6")}
    # the edge rig: 3 m re-made covers neither stale row (the other stale row does not count)
    got = publish("edge", 3.0)
    assert got[("edge", "0.5, 6")] == "commit old" and got[("edge", "1, 3")] == "commit old"
    got = publish("edge", 1.0)
    assert ("edge", "1, 3") not in got and got[("edge", "0.5, 6")] == "commit old"
    # a current row covered in part by a new one stays (only a row all of whose distances are in it goes)
    assert ("wide", "0.5, 1") in publish("wide", 1.0)
    # without ``current``: as before, only a row all of whose distances are in the new one goes
    path.write_text(header + old("0.5, 1, 3, 6"))
    write_published([_row("wide", "jerlov-7C", "disk", 0.01, distance=d) for d in (0.5, 1.0, 3.0)], path,
                    settings="t", engine="commit new")
    write_published([_row("wide", "jerlov-7C", "disk", 0.01, distance=6.0)], path, settings="t", engine="commit new")
    assert ("strobes", "jerlov-7C", "wide", "0.5, 1, 3, 6") in read_published(path)


def test_the_published_table_says_which_fast_engine_each_row_measured(tmp_path, monkeypatch):
    """A row written with ``engine`` reads it back as written (the benchmark's "commit <hash>": text even where
    the hash is all digits, its leading zero kept) and its sentence names it; rows written before the column
    existed, or without an engine, read ""."""
    import rigsim.data
    from rigsim.metrics.agreement import PUBLISHED_TABLE, published_agreement, write_published

    monkeypatch.setattr(rigsim.data, "DATA_DIR", tmp_path)
    path = tmp_path / PUBLISHED_TABLE
    path.parent.mkdir(parents=True)
    # a row of the layout before the column
    path.write_text("lighting,water,rig,cases,distances_m,worst_deviation,worst_se,worst_where,tolerance,beyond,cells,"
                    "measured,settings\nstrobes,coastal,wide,4,\"1, 3\",-0.02,0.01,old,0.05,0,162,2026-12-05,old\n")
    assert published_agreement("coastal").engine == ""
    write_published([_row("wide", "jerlov-9C", "disk", 0.02)], path, settings="test")  # no engine: only blanks
    assert published_agreement("jerlov-9C").engine == "" and published_agreement("coastal").engine == ""
    assert "fast engine of" not in published_agreement("jerlov-9C").sentence("wide")
    write_published([_row("edge", "jerlov-7C", "disk", 0.01)], path, settings="test", engine="commit 0123456")
    new = published_agreement("jerlov-7C", rig="edge")
    assert new.engine == "commit 0123456" and "(fast engine of commit 0123456)" in new.sentence("edge")
    assert published_agreement("coastal").engine == "" and published_agreement("jerlov-9C").worst_deviation == 0.02


def test_the_benchmark_status_lists_the_rows_an_earlier_fast_engine_measured(tmp_path, capsys):
    """``bench_fast_engine_agreement.py --status``: a row measured at a commit whose engine differs from this
    checkout's (the first commit), a "-dirty" one and a blank one are to be made again; one measured at this
    checkout's commit is not (where the checkout's engine has no uncommitted change)."""
    import importlib.util
    import subprocess
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    git = lambda *a: subprocess.run(["git", "-C", str(root), *a], capture_output=True, text=True)  # noqa: E731
    head, first = git("rev-parse", "--short", "HEAD").stdout.strip(), git("rev-list", "--max-parents=0", "HEAD").stdout.split()
    if not head or not first:
        pytest.skip("not a git checkout")
    spec = importlib.util.spec_from_file_location("bench_agreement", root / "benchmarks" / "bench_fast_engine_agreement.py")
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    header = "lighting,water,rig,cases,distances_m,worst_deviation,worst_se,worst_where,tolerance,beyond,cells,measured,engine,settings\n"
    row = lambda water, engine, dev, beyond: (f'strobes,{water},wide,4,"1, 3",{dev},0.01,x,0.05,{beyond},100,'  # noqa: E731
                                              f"2026-12-06,{engine},s\n")
    path = tmp_path / "agreement.csv"
    path.write_text("# a comment line\n" + header + row("jerlov-9C", f"commit {head}", -0.02, 0)
                    + row("jerlov-7C", f"commit {first[0][:7]}", 0.08, 1) + row("jerlov-5C", f"commit {head}-dirty", 0.01, 0)
                    + row("jerlov-3C", "", -0.06, 0)
                    + row("jerlov-7C", f"commit {head}", 0.01, 0).replace('"1, 3"', '"3"'))  # 3 m of 7C re-made
    assert bench.print_status(path) == 0
    out = capsys.readouterr().out
    assert f"{path}: 5 rows, 500 cells, 1 beyond tolerance + t*SE; 2 rows whose worst cell is beyond" in out
    earlier = out.split("earlier engines")[1].split("beyond its bare tolerance")[0]
    assert "jerlov-7C (1, 3 m" in earlier and "jerlov-5C" in earlier and "jerlov-3C" in earlier
    worst = out.split("beyond its bare tolerance, largest first")[1].splitlines()[1:]
    assert [ln.split()[2] for ln in worst] == ["jerlov-7C", "jerlov-3C"]  # +8 % then -6 %; the rows within 5 % not
    assert "+8.0 ± 1.0 %" in worst[0] and worst[0].endswith("earlier engine")
    clean = git("diff", "--quiet", "HEAD", "--", *bench.ENGINE_PATHS).returncode == 0
    assert ("jerlov-9C" not in earlier) == clean
    if clean:
        assert f"this checkout's fast engine (measured at {head}): 2 rows, 200 cells, 0 beyond" in out
        assert "jerlov-7C (1, 3 m; 3 m re-made)" in earlier  # the stale row says which of its distances are in


def test_the_published_line_says_when_the_reference_is_too_noisy_to_show_agreement():
    import dataclasses

    from rigsim.metrics.agreement import PublishedAgreement

    row = PublishedAgreement(lighting="strobes", water="jerlov-III", cases=4, distances_m="1, 3", worst_deviation=-0.12,
                             worst_se=0.11, worst_where="light skin, green, colorchecker at 3 m", tolerance=0.03,
                             beyond=0, cells=162, measured="2026-12-05", settings="test", rig="edge")
    noisy = row.sentence("edge")
    assert "within ±3% or the reference's noise" in noisy and "too noisy there (± 11%)" in noisy
    quiet = dataclasses.replace(row, worst_deviation=-0.02, worst_se=0.01).sentence("edge")
    assert "too noisy" not in quiet
    beyond = dataclasses.replace(row, beyond=8, worst_se=0.02).sentence("edge")
    assert "8 of 162 region values beyond ±3% by more than the reference's noise" in beyond and "too noisy" not in beyond


def _check(contrast_fast, contrast_fast_se, contrast_ref, contrast_ref_se, *, target="colorchecker", seeds=4):
    """A check record (``check.json``) with two patches, the open water and the chart's contrast."""
    region = lambda name, dev: {"region": name, "group": "blue", "pixels": 9, "fast": 1.0 + dev, "reference": 1.0,  # noqa: E731
                                "reference_se": 0.02, "reference_tail": 1.1, "fast_se": 0.0, "deviation": dev,
                                "deviation_se": 0.02}
    return {"rig": "edge", "water": "jerlov-3C", "target": target, "distance_m": 6.0, "c_550_per_m": 1.0,
            "tolerance": 0.05, "width": 96, "height": 64, "spp": 32, "seeds": seeds, "reference": "monte-carlo",
            "regions": [region("patch:white 9.5 (.05 D)", 0.12), region("patch:cyan", -0.02),
                        region("open water", -0.09)],
            "metrics": [MetricDeviation("contrast_radiance", contrast_fast, contrast_ref, contrast_ref_se,
                                        contrast_fast_se).record(),
                        MetricDeviation("backscatter_share", 0.99, 0.99, 0.001).record()]}


def test_a_chart_beyond_its_visibility_in_both_engines_is_listed_not_judged():
    """Issue 18's range ends where the chart's contrast falls below 1 %: a case whose chart is below it in both
    engines (the fast engine's by two of its SE, Monte Carlo's within its 95 % interval) keeps its patch cells,
    verdict "beyond visibility"; the open water is judged as always.  A fast engine that lost a chart Monte Carlo
    sees cannot move its cells out: both must agree."""
    from rigsim.metrics.agreement import BEYOND_VISIBILITY, chart_beyond_visibility, judged
    from rigsim.study.runner import agreement_rows

    # the demo's Jerlov 3C chart at 6 m (2026-12-06): fast 0.15 +- 0.08 %, Monte Carlo 1.19 +- 0.50 % of 4 renders
    unseen = _check(0.0015, 0.0008, 0.0119, 0.0050)
    assert chart_beyond_visibility("colorchecker", unseen["metrics"], 4)
    rows = agreement_rows([unseen])
    by = {r["region"]: r for r in rows if r["quantity"] == "radiance"}
    assert by["patch:white 9.5 (.05 D)"]["verdict"] == BEYOND_VISIBILITY == by["patch:cyan"]["verdict"]
    assert by["patch:white 9.5 (.05 D)"]["deviation"] == 0.12  # the numbers stay in the table
    assert by["open water"]["verdict"] == "within noise"  # -9 % +- 2 % with 4 renders: judged
    contrast = next(r for r in rows if r["quantity"] == "contrast_radiance")  # Monte Carlo's 1.19 % is listed
    assert contrast["verdict"] == BEYOND_VISIBILITY
    assert [r["quantity"] for r in agreement_rows([_check(0.0015, 0.0008, 0.008, 0.002)])
            if r["quantity"] != "radiance"] == ["backscatter_share"]  # a Monte Carlo contrast < 1 %: left out
    assert not judged(by["patch:cyan"]) and judged(by["open water"])
    # Monte Carlo sees the chart (3.0 +- 0.5 %): the fast engine's 0.15 % does not excuse it; judged, and the
    # contrast is compared
    seen = _check(0.0015, 0.0008, 0.030, 0.005)
    assert not chart_beyond_visibility("colorchecker", seen["metrics"], 4)
    rows = agreement_rows([seen])
    assert {r["verdict"] for r in rows if r["region"].startswith("patch:")} == {"disagrees", "agrees"}
    assert any(r["quantity"] == "contrast_radiance" and r["verdict"] == "disagrees" for r in rows)
    # the fast engine sees it (2 %), Monte Carlo does not (0.3 +- 0.1 %): judged too
    assert not chart_beyond_visibility("colorchecker", _check(0.02, 0.001, 0.003, 0.001)["metrics"], 4)
    # the fast engine's own noise: 0.8 +- 0.2 % is not below 1 % by two SE
    assert not chart_beyond_visibility("colorchecker", _check(0.008, 0.002, 0.005, 0.001)["metrics"], 4)
    # Monte Carlo's interval with 8 renders (t = 2.36): 1.19 - 2.36 x 0.10 % < 1 %, 1.19 - 2.36 x 0.05 % > 1 %
    assert chart_beyond_visibility("colorchecker", _check(0.0015, 0.0008, 0.0119, 0.0010)["metrics"], 8)
    assert not chart_beyond_visibility("colorchecker", _check(0.0015, 0.0008, 0.0119, 0.0005)["metrics"], 8)
    # a disk is not a chart; a record without the contrast is judged
    assert not chart_beyond_visibility("black-disk", unseen["metrics"], 4)
    assert not chart_beyond_visibility("colorchecker", unseen["metrics"][1:], 4)


def test_the_published_table_and_the_report_leave_cells_beyond_visibility_out_of_the_worst(tmp_path, monkeypatch):
    import rigsim.data
    from rigsim.metrics.agreement import PUBLISHED_TABLE, published_agreement, write_published
    from rigsim.report.html import trust_section, trust_sentences
    from rigsim.study.runner import agreement_rows

    monkeypatch.setattr(rigsim.data, "DATA_DIR", tmp_path)
    path = tmp_path / PUBLISHED_TABLE
    near = _check(0.5, 0.001, 0.5, 0.001)
    near["distance_m"] = 1.0
    rows = [{**r, "lighting": "strobes"} for r in agreement_rows([near, _check(0.0015, 0.0008, 0.0119, 0.0050)])]
    write_published(rows, path, settings="test")
    row = published_agreement("jerlov-3C", rig="edge")
    # 4 judged radiance cells (the 1 m chart's two patches and both open waters), the 6 m chart's 2 patches not;
    # the worst is the 1 m white patch (+12 %), where the chart is seen
    assert (row.worst_deviation, row.cases, row.cells, row.beyond) == (0.12, 2, 4, 1)
    text = path.read_text()
    assert ",4,2," in text  # cells 4, beyond_visibility 2
    assert row.beyond_visibility == 2 and "2 chart cells where the chart cannot be seen not judged" in row.sentence("edge")
    assert published_agreement("coastal") is None
    # the report: the patch column's worst is the 1 m chart's; the 6 m chart is named as beyond its visibility
    html = "".join(trust_section(tmp_path, [{**r, "distance_m": float(r["distance_m"])} for r in rows], {}))
    assert "the chart at 6 m is beyond its visibility: not judged" in html
    assert "1 chart case lies beyond the chart's visibility" in html
    assert "+12.0%" in trust_sentences(rows, {"engine": "preview"})[0]
    # a study whose only chart is beyond its visibility: the open water is still the worst judged region
    far_only = [{**r, "lighting": "strobes"} for r in agreement_rows([_check(0.0015, 0.0008, 0.0119, 0.0050)])]
    assert "-9.0%" in trust_sentences(far_only, {"engine": "preview"})[0]


def test_a_row_measured_before_commits_that_changed_only_the_check_is_still_this_engines(tmp_path, capsys,
                                                                                         monkeypatch):
    """``CHECK_ONLY_COMMITS``: commits that changed how cells are judged (the visibility rule), not the fast
    engine; a row measured before them is this engine's, one measured before any other engine change is not."""
    import importlib.util
    import subprocess
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    git = lambda *a: subprocess.run(["git", "-C", str(root), *a], capture_output=True, text=True)  # noqa: E731
    spec = importlib.util.spec_from_file_location("bench_agreement2", root / "benchmarks" / "bench_fast_engine_agreement.py")
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    changes = git("rev-list", "HEAD", "--", *bench.ENGINE_PATHS).stdout.split()
    if len(changes) < 3 or git("diff", "--quiet", "HEAD", "--", *bench.ENGINE_PATHS).returncode != 0:
        pytest.skip("needs a git checkout without uncommitted engine edits and a history of engine changes")
    before_last = changes[1]  # measured before the last engine change
    monkeypatch.setattr(bench, "CHECK_ONLY_COMMITS", {})
    assert not bench._same_engine(before_last)
    monkeypatch.setattr(bench, "CHECK_ONLY_COMMITS", {changes[0][:7]: "the last change, called check-only here"})
    assert bench._same_engine(before_last)
    assert not bench._same_engine(changes[2])  # two changes back: the second is not check-only


def test_a_charts_patches_pool_to_an_inverse_variance_mean_and_a_chi2_of_their_scatter():
    from rigsim.metrics.agreement import pooled_patches

    def row(region, dev, se, group="blue", verdict="agrees", distance=1.0):
        return {"lighting": "strobes", "rig": "edge", "water": "jerlov-III", "target": "colorchecker",
                "distance_m": distance, "quantity": "radiance", "region": region, "group": group, "deviation": dev,
                "deviation_se": se, "tolerance": 0.03, "seeds": 8, "verdict": verdict}

    rows = [row("patch:a", 0.02, 0.01), row("patch:b", 0.04, 0.02), row("patch:c", -0.01, 0.01),
            row("open water", 0.5, 0.01),  # not a patch
            row("patch:a", 0.3, 0.01, group="red", verdict="beyond visibility"),  # not judged
            row("patch:b", 0.01, 0.01, group="red")]
    pooled = {p["group"]: p for p in pooled_patches(rows)}
    w = np.array([1e4, 2.5e3, 1e4])
    d = np.array([0.02, 0.04, -0.01])
    mean = (w * d).sum() / w.sum()
    blue = pooled["blue"]
    assert blue["mean"] == pytest.approx(mean) and blue["se"] == pytest.approx(1 / np.sqrt(w.sum()))
    assert blue["chi2"] == pytest.approx((w * (d - mean) ** 2).sum()) and blue["dof"] == 2 and blue["cells"] == 3
    assert (pooled["red"]["cells"], pooled["red"]["mean"], pooled["red"]["dof"]) == (1, 0.01, 0)


def test_the_benchmark_status_read_through_a_closed_pipe_ends_without_a_traceback():
    """``bench_fast_engine_agreement.py --status | head``: the reader leaves early; no traceback."""
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    r = subprocess.run(f"{sys.executable} {root / 'benchmarks' / 'bench_fast_engine_agreement.py'} --status | true",
                       shell=True, capture_output=True, text=True, timeout=120)
    assert "Traceback" not in r.stderr and "BrokenPipeError" not in r.stderr, r.stderr


def test_moderated_noise_estimates_are_closer_to_the_true_noise_than_the_batches_own():
    """:func:`moderated_relative_se` (Smyth 2004) on simulated cases: 75 regions whose true relative noise σ differs
    (σ² from a scaled inverse-χ² with 8 degrees of freedom about 1 %²), each estimated from 4 batches
    (s² = σ² χ²₃ / 3).  Over 400 cases the moderated estimates' mean squared log error is well below the raw
    ones', and an estimate at a third of the truth or less — the raw estimate's 4.5 % chance, which made a fast
    image's own noise read as a disagreement — becomes rare (measured: 1.09 → 0.24; 4.8 % → 0.02 %)."""
    from rigsim.metrics.agreement import moderated_relative_se

    rng = np.random.default_rng(11)
    raw_err, mod_err, raw_low, mod_low = [], [], [], []
    for _ in range(400):
        sigma2 = 1e-4 * 8 / rng.chisquare(8, 75)
        s2 = sigma2 * rng.chisquare(3, 75) / 3
        mod = moderated_relative_se(np.sqrt(s2), 3) ** 2
        raw_err.append(np.log(s2 / sigma2) ** 2)
        mod_err.append(np.log(mod / sigma2) ** 2)
        raw_low.append(s2 <= sigma2 / 9)
        mod_low.append(mod <= sigma2 / 9)
    assert np.mean(mod_err) < 0.5 * np.mean(raw_err), (np.mean(mod_err), np.mean(raw_err))
    assert 0.03 < np.mean(raw_low) < 0.06, np.mean(raw_low)
    assert np.mean(mod_low) < 0.005, np.mean(mod_low)


def test_moderated_noise_pools_a_common_noise_and_leaves_too_few_regions_alone():
    """Regions of one true noise (1 %): the estimates scatter by their chance alone, so each becomes the common
    value, within 10 % of it; six regions (a disk case) are too few to pool and stay as they are; values that
    are not finite and positive are kept."""
    from rigsim.metrics.agreement import MIN_MODERATED, moderated_relative_se

    rng = np.random.default_rng(5)
    s = np.sqrt(1e-4 * rng.chisquare(3, 75) / 3)
    mod = moderated_relative_se(s, 3)
    assert np.all(np.abs(mod / 0.01 - 1) < 0.1), (mod.min(), mod.max())
    few = s[:MIN_MODERATED - 1]
    np.testing.assert_array_equal(moderated_relative_se(few, 3), few)
    odd = s.copy()
    odd[:3] = [0.0, np.nan, np.inf]
    out = moderated_relative_se(odd, 3)
    assert out[0] == 0.0 and np.isnan(out[1]) and np.isinf(out[2]) and np.all(np.isfinite(out[3:]))



def test_the_published_table_keeps_each_rows_cells_and_drops_those_of_a_row_it_replaces(tmp_path, monkeypatch):
    """``write_published(..., cells_dir=...)`` writes every cell of each new row (radiance cells and the row's
    metric cells) to one gzip file per row, byte-identical for the same cells; a row that a later run supersedes
    loses its cells file with its line, and a row of other distances keeps its own."""
    import rigsim.data
    from rigsim.metrics.agreement import PUBLISHED_TABLE, cells_file_name, read_cells, write_published

    monkeypatch.setattr(rigsim.data, "DATA_DIR", tmp_path)
    path, cells = tmp_path / PUBLISHED_TABLE, tmp_path / "cells"
    contrast = {**_row("wide", "jerlov-9C", "target", 0.3), "quantity": "contrast_radiance",
                "fast": 0.1234567891, "monte_carlo": 0.11, "pixels": 12, "seeds": 4}
    first = [_row("wide", "jerlov-9C", "disk", 0.02), _row("wide", "jerlov-9C", "open water", -0.04123456789),
             contrast, _row("edge", "jerlov-9C", "disk", 0.01)]
    write_published(first, path, settings="test", cells_dir=cells, cells_header="the command")
    f = cells / cells_file_name("strobes", "jerlov-9C", "wide", "1")
    assert f.name == "strobes__jerlov-9C__wide__1.csv.gz"
    got = read_cells(f)
    assert [(r["quantity"], r["region"]) for r in got] == [("radiance", "disk"), ("radiance", "open water"),
                                                          ("contrast_radiance", "target")]
    assert got[1]["deviation"] == "-0.0412346" and got[2]["fast"] == "0.123457" and got[2]["pixels"] == "12"
    assert [r["rig"] for r in read_cells(cells / cells_file_name("strobes", "jerlov-9C", "edge", "1"))] == ["edge"]
    assert "# the command" in gzip.decompress(f.read_bytes()).decode().splitlines()[2]
    once = f.read_bytes()
    write_published(first, path, settings="test", cells_dir=cells, cells_header="the command")
    assert f.read_bytes() == once  # no time stamp in the file: the same cells, the same bytes
    # 6 m beside it: a second file; then 1 and 6 m together supersede both rows and both files
    write_published([_row("wide", "jerlov-9C", "disk", 0.05, distance=6.0)], path, settings="test", cells_dir=cells)
    assert (cells / "strobes__jerlov-9C__wide__6.csv.gz").is_file() and f.is_file()
    write_published([_row("wide", "jerlov-9C", "disk", 0.01, distance=d) for d in (1.0, 6.0)], path,
                    settings="test", cells_dir=cells)
    assert sorted(p.name for p in cells.iterdir()) == ["strobes__jerlov-9C__edge__1.csv.gz",
                                                       "strobes__jerlov-9C__wide__1-6.csv.gz"]


def test_every_published_cells_file_is_the_row_it_stands_beside():
    """The committed cells (data/fast_engine/cells) against the committed table: each file has its row, and the
    row's worst cell, its count of judged cells and of cells beyond are the file's (a row re-made without its
    cells, or cells left from a row since replaced, fail here)."""
    import csv

    from rigsim.metrics.agreement import cells_file_name, judged, read_cells

    root = Path(__file__).resolve().parents[2] / "data" / "fast_engine"
    with open(root / "agreement.csv", newline="") as fh:
        table = {cells_file_name(r["lighting"], r["water"], r["rig"], r["distances_m"]): r
                 for r in csv.DictReader(ln for ln in fh if not ln.startswith("#"))}
    files = sorted((root / "cells").glob("*.csv.gz"))
    assert files, "no cells files beside the published table"
    for f in files:
        assert f.name in table, f"{f.name}: no row of agreement.csv"
        row, got = table[f.name], read_cells(f)
        radiance = [r for r in got if r["quantity"] == "radiance"]
        rs = [r for r in radiance if judged(r)] or radiance
        worst = max(rs, key=lambda r: abs(float(r["deviation"])))
        assert abs(float(worst["deviation"]) - float(row["worst_deviation"])) < 6e-5, f.name
        assert abs(float(worst["deviation_se"]) - float(row["worst_se"])) < 6e-5, f.name
        assert sum(judged(r) for r in radiance) == int(row["cells"]), f.name
        assert sum(r["verdict"] == "disagrees" for r in rs) == int(row["beyond"]), f.name
        assert {r["rig"] for r in got} == {row["rig"]} and {r["water"] for r in got} == {row["water"]}, f.name


def test_a_fast_image_judged_against_kept_cells_reads_as_against_the_renders_they_came_from(tmp_path):
    """``compare_to_cells``: the cells a row keeps (``agreement_rows`` of a check, through ``write_cells`` /
    ``read_cells``, 6 significant digits) stand for the Monte Carlo renders they summarise — a changed fast
    image (another level, other photon batches) gets the deviations, standard errors and verdict inputs that
    ``compare_renders`` gives it against those renders, region by region and for the metrics; a fast image whose
    regions are not the cells' is refused."""
    from rigsim.metrics.agreement import compare_renders, compare_to_cells, read_cells, write_cells
    from rigsim.spectral_image import SpectralImage
    from rigsim.study.runner import agreement_rows

    wl = np.array([450.0, 550.0, 650.0])
    rows, cols = 30, 40
    y, x = np.mgrid[0:rows, 0:cols]
    oid = (((y - 15) ** 2 + (x - 20) ** 2) <= 25).astype(np.int32)
    truth = np.where(oid == 1, 0.6, 1.0)[..., None] * np.array([0.8, 1.0, 1.2])
    rng = np.random.default_rng(11)

    def img(a, o=oid):
        return SpectralImage(radiance=a.astype(np.float32), wavelength_nm=wl, bandwidth_nm=np.full(3, 100.0),
                             layers={"object_id": o}, meta={"object_ids": {"1": "disk"}})

    def batches(level):
        return [img(level * truth * (1 + 0.2 * rng.standard_normal((rows, cols, 1)))) for _ in range(4)]

    refs = [img(truth * (1 + 0.3 * rng.standard_normal((rows, cols, 1)))) for _ in range(6)]
    own = batches(1.0)
    fast = img(np.mean([np.asarray(b.radiance) for b in own], axis=0))
    regions, metrics = compare_renders(fast, refs, "black-disk", fast_batches=own, noise_batches=[batches(1.0)])
    rec = {"rig": "wide", "water": "jerlov-9C", "target": "black-disk", "distance_m": 1.0, "tolerance": 0.05,
           "width": cols, "height": rows, "spp": 32, "seeds": len(refs), "reference": "monte-carlo",
           "regions": [r.record() for r in regions], "metrics": [m.record() for m in metrics]}
    write_cells(tmp_path / "row.csv.gz", agreement_rows([rec]))
    kept = read_cells(tmp_path / "row.csv.gz")
    # the engine changed: its image 4 % higher, other photons
    own2 = batches(1.04)
    fast2 = img(np.mean([np.asarray(b.radiance) for b in own2], axis=0))
    extra2 = [batches(1.04)]
    want_r, want_m = compare_renders(fast2, refs, "black-disk", fast_batches=own2, noise_batches=extra2)
    got_r, got_m = compare_to_cells(fast2, kept, "black-disk", fast_batches=own2, noise_batches=extra2)
    assert [(r.region, r.group) for r in got_r] == [(r.region, r.group) for r in want_r] and len(got_r) == 6
    for g, w in zip(got_r, want_r):
        assert g.deviation == pytest.approx(w.deviation, rel=1e-5, abs=1e-5)
        assert g.deviation_se == pytest.approx(w.deviation_se, rel=1e-5)
        assert g.reference_tail == pytest.approx(w.reference_tail, rel=1e-5)
        assert g.fast == w.fast and g.fast_se == w.fast_se
    assert [m.metric for m in got_m] == [m.metric for m in want_m] and got_m[0].metric == "contrast_radiance"
    for g, w in zip(got_m, want_m):  # (a value kept to 6 digits: the deviation to ~1e-5 of the reference)
        assert g.deviation == pytest.approx(w.deviation, rel=1e-5, abs=1e-5)
        assert g.deviation_se == pytest.approx(w.deviation_se, rel=1e-5)
    assert abs(got_r[0].deviation - regions[0].deviation) > 0.02  # the change shows
    moved = np.where(oid == 1, 0, 1).astype(np.int32)  # another scene's regions: the kept cells do not apply
    moved[:3] = 1
    with pytest.raises(ValueError, match="not the kept cells'"):
        compare_to_cells(img(np.asarray(fast2.radiance), moved), kept, "black-disk")


def _fast_snapshot_module():
    import importlib.util
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    spec = importlib.util.spec_from_file_location("fast_snapshot", root / "benchmarks" / "fast_snapshot.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return root, mod


def test_a_restamped_row_keeps_its_numbers_and_says_why(tmp_path, monkeypatch):
    """``--verify-unchanged --publish``: a row whose fast images a later engine makes bit for bit gets that engine in
    its engine column and the reason in its settings; its numbers, its date and the other rows stay, and its line
    names the engine that measured it and the one that makes the same images."""
    import rigsim.data
    from rigsim.metrics.agreement import (PUBLISHED_TABLE, published_agreement, read_published, restamp_published,
                                         write_published)

    path = tmp_path / PUBLISHED_TABLE
    write_published([_row("wide", "jerlov-9C", "disk", 0.02), _row("edge", "jerlov-7C", "disk", 0.01)], path,
                    settings="96x64 px", engine="commit 0123456")
    before = read_published(path)
    key = next(k for k in before if k[1] == "jerlov-9C")
    assert restamp_published(path, {key: ("commit 89abcde", "fast images identical to those of commit 0123456"),
                                     ("strobes", "nowhere", "x", "1"): ("commit 89abcde", "no such row")}) == 1
    after = read_published(path)
    assert after[key]["engine"] == "commit 89abcde"
    assert after[key]["settings"] == "96x64 px; fast images identical to those of commit 0123456"
    for col in ("worst_deviation", "worst_se", "worst_where", "cells", "beyond", "measured"):
        assert after[key][col] == before[key][col], col
    other = next(k for k in before if k[1] == "jerlov-7C")
    assert after[other] == before[other] and len(after) == 2
    monkeypatch.setattr(rigsim.data, "DATA_DIR", tmp_path)  # what the rig designer shows: the engine that measured it
    assert published_agreement("jerlov-9C", rig="wide").sentence("wide").endswith(
        "(fast engine of commit 0123456; commit 89abcde makes the same images)")
    assert published_agreement("jerlov-7C", rig="edge").sentence("edge").endswith("(fast engine of commit 0123456)")


def test_fast_snapshots_are_compared_bit_for_bit(tmp_path):
    """The verification's comparison: the same arrays (NaN as NaN) are identical; one value one ulp apart, another
    dtype or a missing array is a change, named."""
    _, snap = _fast_snapshot_module()
    a = {"chart@1/radiance": np.linspace(0.0, 1.0, 12).reshape(3, 4), "chart@1/range_m": np.array([1.0, np.inf, np.nan])}
    np.savez(tmp_path / "a.npz", **a)
    np.savez(tmp_path / "b.npz", **a)
    assert snap.same_arrays(tmp_path / "a.npz", tmp_path / "b.npz") == (True, "2 arrays identical")
    nudged = dict(a, **{"chart@1/radiance": a["chart@1/radiance"].copy()})
    nudged["chart@1/radiance"][1, 2] = np.nextafter(nudged["chart@1/radiance"][1, 2], 2.0)
    np.savez(tmp_path / "c.npz", **nudged)
    ok, why = snap.same_arrays(tmp_path / "a.npz", tmp_path / "c.npz")
    assert not ok and why.startswith("chart@1/radiance differs")
    np.savez(tmp_path / "d.npz", **dict(a, **{"chart@1/radiance": a["chart@1/radiance"].astype(np.float32)}))
    assert not snap.same_arrays(tmp_path / "a.npz", tmp_path / "d.npz")[0]
    np.savez(tmp_path / "e.npz", **{"chart@1/radiance": a["chart@1/radiance"]})
    ok, why = snap.same_arrays(tmp_path / "a.npz", tmp_path / "e.npz")
    assert not ok and "range_m" in why


def test_a_snapshot_is_of_the_rows_study_and_of_the_checkouts_own_package(tmp_path):
    """The study a snapshot renders is the published row's (its rig or the daylight depth, water, distances, image
    size, multiple scattering), and a snapshot refuses a checkout whose package is not the one imported (both sides
    would then be one code and always identical)."""
    from rigsim.study import load_study

    root, snap = _fast_snapshot_module()
    row = {"lighting": "daylight-15m", "water": "jerlov-3C", "rig": "ambient-only", "distances_m": "0.5, 6",
           "settings": "96x64 px, multiple scattering auto, Monte Carlo 4-256 x 32 spp"}
    (tmp_path / "s.toml").write_text(snap._study_text(root, row))
    spec = load_study(tmp_path / "s.toml")
    cases = spec.check_cases()
    assert sorted({(c.target, c.distance_m, c.depth_m, c.water_name, c.rig_name) for c in cases}) == [
        ("black-disk", 0.5, 15.0, "jerlov-3C", "ambient-only"), ("black-disk", 6.0, 15.0, "jerlov-3C", "ambient-only"),
        ("colorchecker", 0.5, 15.0, "jerlov-3C", "ambient-only"), ("colorchecker", 6.0, 15.0, "jerlov-3C", "ambient-only")]
    assert (spec.check.width, spec.check.height, spec.render.preview_multiple) == (96, 64, "auto")
    strobes = dict(row, lighting="strobes", rig="twin-strobes-edge-lighting", settings="48x32 px, multiple scattering off")
    (tmp_path / "t.toml").write_text(snap._study_text(root, strobes))
    spec = load_study(tmp_path / "t.toml")
    assert {c.rig_name for c in spec.check_cases()} == {"twin-strobes-edge-lighting"}
    assert (spec.check.width, spec.render.preview_multiple, spec.check_cases()[0].depth_m) == (48, False, None)
    with pytest.raises(ValueError, match="image size"):
        snap._study_text(root, dict(row, settings="Monte Carlo only"))
    with pytest.raises(SystemExit, match="PYTHONPATH"):
        snap.snapshot(tmp_path, [row], tmp_path / "out")


def _bench_module(name: str):
    import importlib.util
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    spec = importlib.util.spec_from_file_location(name, root / "benchmarks" / "bench_fast_engine_agreement.py")
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    return bench


def _table_row(lighting, water, rig, distances, dev, engine, tol=0.05):
    return {"lighting": lighting, "water": water, "rig": rig, "distances_m": distances, "worst_deviation": str(dev),
            "worst_se": "0.01", "worst_where": "x", "tolerance": str(tol), "beyond": "0", "cells": "10",
            "engine": engine}


def test_remake_plans_the_distances_no_current_row_covers_rows_beyond_their_tolerance_first():
    """``--remake``'s plan: each distance of a row of an earlier engine that this engine's rows do not cover; the rows
    whose worst cell is beyond the bare tolerance first (largest first), then the 3 % waters, then the rest; a current
    row (beyond or not) is not in it; daylight rows get the daylight command, strobe rows the hybrid one."""
    bench = _bench_module("bench_agreement_remake")
    rows = [_table_row("strobes", "coastal", "edge", "0.5, 1, 3, 6", -0.04, "commit old"),      # within: last
            _table_row("strobes", "jerlov-7C", "edge", "0.5, 1, 3, 6", -0.23, "commit old"),    # beyond, largest
            _table_row("strobes", "jerlov-7C", "edge", "1", 0.01, "commit new"),                # 1 m re-made
            _table_row("strobes", "jerlov-1C", "wide", "1, 3", 0.06, "commit old"),             # beyond
            _table_row("strobes", "clear", "port", "3", 0.01, "commit old", tol=0.03),          # within, 3 %
            _table_row("daylight-5m", "jerlov-II", "ambient-only", "6", 0.0, ""),               # blank engine
            _table_row("strobes", "jerlov-III", "edge", "0.5, 3", -0.15, "commit new", tol=0.03)]  # current
    table = {(r["lighting"], r["water"], r["rig"], r["distances_m"]): r for r in rows}
    plan = bench.remake_plan(table, lambda r: r["engine"] == "commit new")
    assert plan == [("strobes", "edge", "jerlov-7C", 0.5), ("strobes", "edge", "jerlov-7C", 3.0),
                    ("strobes", "edge", "jerlov-7C", 6.0), ("strobes", "wide", "jerlov-1C", 1.0),
                    ("strobes", "wide", "jerlov-1C", 3.0), ("strobes", "port", "clear", 3.0),
                    ("strobes", "edge", "coastal", 0.5), ("strobes", "edge", "coastal", 1.0),
                    ("strobes", "edge", "coastal", 3.0), ("strobes", "edge", "coastal", 6.0),
                    ("daylight-5m", "ambient-only", "jerlov-II", 6.0)]
    from pathlib import Path
    cmd = bench.remake_command(plan[0], Path("/o"))
    assert cmd[:2] == ["--rigs", "edge"] and "hybrid" in cmd and cmd[cmd.index("--distances") + 1] == "0.5"
    assert cmd[cmd.index("--out") + 1] == "/o/strobes__jerlov-7C__edge" and "--publish" in cmd
    day = bench.remake_command(plan[-1], Path("/o"))
    assert day[day.index("--rigs") + 1] == "" and day[day.index("--depths") + 1] == "5" and "hybrid" not in day
    with pytest.raises(ValueError):
        bench.remake_command(("flash-only", "x", "y", 1.0), Path("/o"))


def test_remake_runs_each_distance_once_and_goes_on_where_the_table_stands(tmp_path, monkeypatch, capsys):
    """The ``--remake`` loop: the plan read again before every run (a run that published drops out of it), a failed
    run not tried again in the same invocation (exit 1 at the end), nothing started on uncommitted engine code."""
    from rigsim.metrics.agreement import _write_published_table, read_published

    bench = _bench_module("bench_agreement_remake2")
    path = tmp_path / "agreement.csv"
    rows = [_table_row("strobes", "coastal", "edge", "1, 3", 0.01, "commit old")]
    _write_published_table(path, {(r["lighting"], r["water"], r["rig"], r["distances_m"]): r for r in rows})
    monkeypatch.setattr(bench, "PUBLISHED", path)
    monkeypatch.setattr(bench, "_engine_is_current", lambda e: e == "commit new")
    monkeypatch.setattr(bench, "_engine_id", lambda: "commit new-dirty")
    assert bench.remake(tmp_path / "out", hours=None, dry_run=False, waters=None, rigs=None) == 1
    assert "commit it before --remake" in capsys.readouterr().err
    monkeypatch.setattr(bench, "_engine_id", lambda: "commit new")
    runs = []

    class FakeRun:  # the child: 1 m publishes a current row, 3 m fails
        def __init__(self, argv, **kw):
            d = argv[argv.index("--distances") + 1]
            runs.append(d)
            self.rc = 0 if d == "1" else 1
            if d == "1":
                t = read_published(path)
                r = _table_row("strobes", "coastal", "edge", "1", 0.02, "commit new")
                t[(r["lighting"], r["water"], r["rig"], r["distances_m"])] = r
                _write_published_table(path, t)

        def wait(self):
            return self.rc

    monkeypatch.setattr("subprocess.Popen", FakeRun)
    assert bench.remake(tmp_path / "out", hours=None, dry_run=False, waters=None, rigs=None) == 1
    out = capsys.readouterr().out
    assert runs == ["1", "3"]  # each once: 1 m left the plan by publishing, 3 m failed and is not tried again
    assert "worst +2.0 ± 1.0 %" in out and "failed (exit 1)" in out and "done: nothing left" in out
    runs.clear()
    assert bench.remake(tmp_path / "out", hours=None, dry_run=True, waters=None, rigs=None) == 0
    assert runs == [] and "1 distances of rows of earlier engines" in capsys.readouterr().out
    assert bench.remake(tmp_path / "out", hours=None, dry_run=False, waters={"clear"}, rigs=None) == 0
    assert runs == []  # nothing of that water to make
