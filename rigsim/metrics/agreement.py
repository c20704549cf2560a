"""How far the fast engine agrees with Monte Carlo: region means of two renders of one scene.

A study that renders with the fast engine (:mod:`rigsim.preview`) also renders a few of its cases
with the Monte Carlo renderer (:mod:`rigsim.render`) as ``seeds`` independent renders.  For every
region of the image — each ColorChecker patch, the disk, the open-water veil — and every colour
group of bands (:data:`rigsim.spectrum.COLOUR_GROUPS_NM`), the fast engine's region mean of the
radiant exposure (one flash plus 1 s of continuous light, :meth:`SpectralImage.radiant_exposure`)
is compared with the mean of the Monte Carlo renders' region means; the reference's standard
error is the spread of those means over √seeds, the fast engine's the spread of its region mean over
the images made with each batch of its multiple-scattering photons (where it traced any), and the
difference's standard error is both together.  The scene metrics the study reports
(``contrast_radiance``, ``backscatter_share``, :func:`rigsim.metrics.scene.scene_metrics`; with marine
snow ``speck_share``) are ratios of region means: they are measured on the mean of the renders (and of
the fast engine's batches), with jackknife standard errors (:func:`pooled_metric`; until 2026-12-04 each
render's own was averaged, which the renders' noise biased: a contrast of 0.004 read 0.125), and the
contrast is compared only where Monte Carlo's is at least :data:`MIN_CONTRAST`.

The comparison's range ends where the chart can no longer be seen (issue 18: "0.5–6 m, or to where the
chart's contrast falls below 1 %"): in a case whose ColorChecker's white-against-black contrast is below
:data:`MIN_CONTRAST` in both engines — the fast engine's below it by two of its standard errors, Monte Carlo's
within its 95 % interval (:func:`chart_beyond_visibility`) — the patch cells are kept, with their numbers, but
get the verdict ``beyond visibility`` instead of a judgement (Jerlov 3C at 6 m: 0.15 % and 1.2 ± 0.5 %; there
a patch is the veil in front of it, measured as the open water is).  Both engines must place the chart below
1 %, so a fast engine that lost a visible chart's light cannot move its own cells out of the comparison.

Regions are taken from the fast engine's object-id layer, without edge pixels: a patch or the disk
eroded by one pixel (:func:`rigsim.metrics.scene.target_masks`), the open water farther than
``margin`` of the image width from every target pixel.  The two engines sample a pixel's footprint
differently (the fast engine at its centre, Monte Carlo over it), so pixels on an edge differ by
tens of percent between them without either being wrong.

Tolerances: 3 % in clear water, 5 % elsewhere (the fast engine's design targets); a cell is
``agrees`` within its tolerance, ``within noise`` if the difference is inside the tolerance plus the
difference's 95 % confidence half-width — ``t · SE`` with Student's t for the number of renders less
one (Student 1908: the spread of 4 renders estimates their standard error with 3 degrees of freedom,
t = 3.18; "2 SE" is an 86 % interval for 4 renders: a fast value just at the tolerance was called a
disagreement in one check in seven) — else ``disagrees``.

The standard error is only as good as the renders' spread.  Where Monte Carlo's estimator is
heavy-tailed — chart patches lit by strobe light scattered many times in high-albedo water (Jerlov III,
5C–9C: ``benchmarks/bench_reference_hybrid.py``, ``benchmarks/bench_reference_convergence.py``) — most
sets of renders miss the rare large paths, so their mean is low and their spread small, and now and then
one render holds many times the others.  Each region value therefore also carries ``reference_tail``,
the largest render's region mean over the median render's: 1.0–1.6 for light-tailed regions over up to
64 renders of 32 paths per pixel (open water, chart patches in coastal water), 3–55 where a render caught
such a path (:data:`HEAVY_TAIL`).  A large tail says that cell's reference is not converged, whichever
way its verdict went; a small one does not prove it is (the rare paths may not have been drawn).
For a chart lit by strobes or continuous lights a check can take hybrid images instead of renders (``[check]
reference = "hybrid"``, :mod:`rigsim.render.hybrid`): the chart's light traced from the lights (bounded weights) and
seen through the water by a camera pass, plus the renders' veil — compared here exactly as renders are
(Jerlov 7C, edge-lit rig, chart at 1 m: the largest hybrid image 1.9× the median, against up to 1 733×).
"""

from __future__ import annotations

import dataclasses
import math
import re
from collections.abc import Callable
from dataclasses import asdict, dataclass

import numpy as np

from rigsim.metrics.scene import scene_metrics, target_masks
from rigsim.metrics.specks import has_particle_layer
from rigsim.spectral_image import SPECTRAL_LAYERS
from rigsim.spectrum import colour_groups

__all__ = ["RegionDeviation", "MetricDeviation", "CLEAR_WATERS", "MIN_CONTRAST", "PublishedAgreement",
           "published_agreement", "write_published", "write_cells", "read_cells", "read_cells_header",
           "cells_file_name", "CELL_COLUMNS", "PUBLISHED_TABLE", "tolerance_for", "comparison_regions",
           "compare_renders", "compare_to_cells", "fast_estimates", "FastEstimates", "moderated_relative_se",
           "MIN_MODERATED", "verdict", "noise_multiplier", "relative_se", "HEAVY_TAIL", "heavy_tailed", "case_key",
           "target_tails", "mean_image", "pooled_metric", "BEYOND_VISIBILITY", "chart_beyond_visibility",
           "contrast_below_visibility", "judged", "pooled_patches", "PUBLISHED_COLUMNS", "read_published",
           "restamp_published", "distance_set"]

#: Waters in which the fast engine should agree within 3 % (Jerlov's oceanic types I–III and the
#: original write-up's clear waters); elsewhere 5 %.
CLEAR_WATERS = frozenset({"jerlov-I", "jerlov-IA", "jerlov-IB", "jerlov-II", "jerlov-III", "pure-sea", "clear",
                          "oceanic"})


#: Contrasts are compared where the Monte Carlo contrast is at least this (1 %): below it the target
#: is invisible, and a relative difference of two tiny contrasts says nothing about the picture.
MIN_CONTRAST = 0.01

#: The verdict of a chart patch's cell in a case whose chart is not visible in either engine
#: (:func:`chart_beyond_visibility`): listed, not judged.
BEYOND_VISIBILITY = "beyond visibility"


#: A reference whose largest render's region mean is at least this many times the median render's is
#: called heavy-tailed (:attr:`RegionDeviation.reference_tail`).  Measured 2026-12-04, 96×64, 32 paths per
#: pixel (``benchmarks/bench_reference_convergence.py``): light-tailed regions 1.0–1.6 over 4–64 renders
#: (coastal-regions chart and water at 1 m; the open water of Jerlov III at 3 m and 9C at 1 m); Jerlov III's
#: white patch at 3 m 10–11 once 32 renders held its rare paths; Jerlov 9C's patches at 1 m 1.8–8 over 48
#: renders, one 54.
HEAVY_TAIL = 3.0


def heavy_tailed(tail) -> bool:
    """Whether a reference's ``largest / median render`` (:attr:`RegionDeviation.reference_tail`) marks it
    heavy-tailed (:data:`HEAVY_TAIL`); False where it is unknown."""
    try:
        return math.isfinite(float(tail)) and float(tail) >= HEAVY_TAIL
    except (TypeError, ValueError):
        return False


def case_key(row: dict) -> tuple:
    """The checked case an agreement row (``agreement.csv``) belongs to."""
    return tuple(row.get(k) for k in ("lighting", "rig", "water", "target", "distance_m"))


def target_tails(rows: list[dict]) -> dict[tuple, float]:
    """Per checked case (:func:`case_key`), the largest ``monte_carlo_tail`` over its target's radiance rows
    (chart patches, disk).  The tail belongs to the estimator in that scene more than to one cell: a set of
    renders that drew none of a patch's rare paths has a small spread and a low mean — the cells that come
    out ``disagrees`` (in the agreement benchmark of 2026-12-04 every such chart cell had a tail of 1.0–1.9)
    — while its neighbour patches show them.  Rendered 48–64 times, such cells moved to within noise
    (``benchmarks/bench_reference_convergence.py``)."""
    out: dict[tuple, float] = {}
    for r in rows:
        if r.get("quantity") != "radiance" or not (str(r.get("region", "")).startswith("patch:") or r.get("region") == "disk"):
            continue
        try:
            t = float(r.get("monte_carlo_tail"))
        except (TypeError, ValueError):
            continue
        if math.isfinite(t):
            k = case_key(r)
            out[k] = max(out.get(k, 0.0), t)
    return out


def tolerance_for(water_name: str) -> float:
    """The agreement the fast engine is held to in a water (a fraction): 0.03 in clear waters, else 0.05."""
    return 0.03 if water_name in CLEAR_WATERS else 0.05


def noise_multiplier(seeds: int | None) -> float:
    """Half-width of the reference's 95 % confidence interval in standard errors: Student's t at 0.975 with
    ``seeds − 1`` degrees of freedom (2 when the number of renders is unknown or below 2)."""
    if seeds is None or not isinstance(seeds, (int, float)) or seeds < 2:
        return 2.0
    from scipy.stats import t

    return float(t.ppf(0.975, int(seeds) - 1))


def verdict(deviation: float, se: float, tolerance: float, seeds: int | None = None) -> str:
    """``agrees`` (|deviation| <= tolerance), ``within noise`` (<= tolerance + t·SE, :func:`noise_multiplier`
    of ``seeds``) or ``disagrees``."""
    if not math.isfinite(deviation):
        return "no reference"
    if abs(deviation) <= tolerance:
        return "agrees"
    if math.isfinite(se) and abs(deviation) <= tolerance + noise_multiplier(seeds) * se:
        return "within noise"
    return "disagrees"


def judged(row: dict) -> bool:
    """Whether an agreement row (``agreement.csv``) carries a judgement (not ``beyond visibility``)."""
    return row.get("verdict") != BEYOND_VISIBILITY


def pooled_patches(rows: list[dict]) -> list[dict]:
    """Per checked chart and colour group, its judged patch cells pooled: the inverse-variance mean of their
    deviations ``mean`` ± ``se`` (a bias common to the patches, with their noise averaged down), and the cells'
    scatter about it, ``chi2`` with ``dof`` = cells − 1 (``chi2 / dof`` near 1: the cells differ by their noise
    alone; well above 1: the fast engine errs differently on different patches, or a reference is heavy-tailed).

    ``rows``: agreement rows (``agreement.csv``).  A chart whose cells are each within noise but whose pooled mean
    is beyond its tolerance is off as a whole; one whose pooled mean is within it and whose ``chi2 / dof`` is near 1
    agrees, its worst cells being the largest of many noisy draws."""
    from collections import defaultdict

    by = defaultdict(list)
    for r in rows:
        if r.get("quantity") != "radiance" or not str(r.get("region", "")).startswith("patch:") or not judged(r):
            continue
        try:
            d, s = float(r["deviation"]), float(r["deviation_se"])
        except (KeyError, TypeError, ValueError):
            continue
        if math.isfinite(d) and math.isfinite(s) and s > 0:
            by[case_key(r) + (r.get("group"),)].append((d, s, r))
    out = []
    for key, cells in by.items():
        d = np.array([c[0] for c in cells])
        w = 1.0 / np.array([c[1] for c in cells]) ** 2
        mean = float((w * d).sum() / w.sum())
        first = cells[0][2]
        out.append({"lighting": key[0], "rig": key[1], "water": key[2], "target": key[3], "distance_m": key[4],
                    "group": key[5], "tolerance": first.get("tolerance"), "seeds": first.get("seeds"),
                    "cells": len(cells), "mean": mean, "se": float(1.0 / math.sqrt(w.sum())),
                    "chi2": float((w * (d - mean) ** 2).sum()), "dof": len(cells) - 1})
    return out


def chart_beyond_visibility(target: str, metrics: list[dict], seeds: int | None) -> bool:
    """Whether a checked case lies beyond its chart's visibility: a ``colorchecker`` whose contrast
    (``contrast_radiance`` in ``metrics``, :meth:`MetricDeviation.record` dicts) is below :data:`MIN_CONTRAST` in
    both engines — the fast engine's by two of its standard errors, Monte Carlo's within its 95 % interval
    (:func:`noise_multiplier` of ``seeds``).  False where the contrast was not recorded."""
    if target != "colorchecker":
        return False
    m = next((x for x in metrics if x.get("metric") == "contrast_radiance"), None)
    if m is None:
        return False
    try:
        fast, fast_se = float(m["fast"]), float(m.get("fast_se") or 0.0)
        ref, ref_se = float(m["reference"]), float(m["reference_se"])
    except (KeyError, TypeError, ValueError):
        return False
    if not all(math.isfinite(x) for x in (fast, ref)):
        return False
    return contrast_below_visibility(fast, fast_se, ref, ref_se, seeds)


def contrast_below_visibility(fast: float, fast_se: float, ref: float | None, ref_se: float, seeds: int | None) -> bool:
    """The rule of :func:`chart_beyond_visibility` on the numbers: the fast contrast below :data:`MIN_CONTRAST` by two
    of its standard errors and the reference's within its 95 % interval; ``ref`` None: a reference contrast that a
    published row left out for being below the limit (:func:`rigsim.study.runner.agreement_rows`)."""
    fast_se = fast_se if math.isfinite(fast_se) else 0.0
    if ref is None:
        return fast + 2.0 * fast_se < MIN_CONTRAST
    ref_se = ref_se if math.isfinite(ref_se) else 0.0
    return fast + 2.0 * fast_se < MIN_CONTRAST and ref - noise_multiplier(seeds) * ref_se < MIN_CONTRAST


def relative_se(reference: float, reference_se: float) -> float:
    """The standard error of ``fast / reference − 1`` for a noiseless ``fast``: ``reference_se / |reference|``.

    This is the scale on which :func:`verdict` tests the difference (``|fast − reference| ≤
    (tolerance + 2 SE) · reference``).  The first-order error of the ratio, ``fast · se / reference²``,
    shrinks as ``fast`` falls below the reference and would call a fast value a third of a reference
    with 50 % noise a clear disagreement (it was used until 2026-12-02: a Jerlov 3C contrast of 0.6 %
    against Monte Carlo's 2.4 ± 1.1 % came out as −74 ± 12 %).
    """
    return abs(reference_se / reference) if reference != 0 else float("nan")


@dataclass(frozen=True)
class RegionDeviation:
    """One region × colour group: the fast engine's mean against Monte Carlo's.

    ``fast`` and ``reference`` are region means of the radiant exposure (J·m⁻²·sr⁻¹·nm⁻¹ averaged
    over the group's bands); ``deviation`` = fast / reference − 1 and ``deviation_se`` its standard
    error, ``hypot(reference_se, fast_se) / reference`` (:func:`relative_se`): the reference's noise and
    the fast engine's.  The analytic part of the fast engine has none, but its multiply scattered light
    (:mod:`rigsim.preview.multiple`, in the waters that scatter widely) is traced with photons:
    ``fast_se`` is the spread of the region's mean over the images made with each batch of them
    (:func:`rigsim.preview.render_photon_batches`) over √batches, moderated over the case's regions
    (:func:`moderated_relative_se`), 0 where none were traced or none given (until 2026-12-04 it was left out:
    in Jerlov 9C at 1 m 2–3 % of the blue open-water veil between seeds).  ``reference_tail`` is the largest
    render's region mean over the median render's (module docstring, :data:`HEAVY_TAIL`; NaN if unknown).
    """

    region: str
    group: str
    pixels: int
    fast: float
    reference: float
    reference_se: float
    reference_tail: float = float("nan")
    fast_se: float = 0.0

    @property
    def deviation(self) -> float:
        return self.fast / self.reference - 1.0 if self.reference > 0 else float("nan")

    @property
    def deviation_se(self) -> float:
        return relative_se(self.reference, math.hypot(self.reference_se, self.fast_se))

    def record(self) -> dict:
        return {**asdict(self), "deviation": self.deviation, "deviation_se": self.deviation_se}


@dataclass(frozen=True)
class MetricDeviation:
    """One scene metric (``contrast_radiance``, ``backscatter_share``): fast against Monte Carlo (``fast_se``
    as :class:`RegionDeviation`'s)."""

    metric: str
    fast: float
    reference: float
    reference_se: float
    fast_se: float = 0.0

    @property
    def deviation(self) -> float:
        return self.fast / self.reference - 1.0 if self.reference != 0 else float("nan")

    @property
    def deviation_se(self) -> float:
        return relative_se(self.reference, math.hypot(self.reference_se, self.fast_se))

    def record(self) -> dict:
        return {**asdict(self), "deviation": self.deviation, "deviation_se": self.deviation_se}


def comparison_regions(object_id: np.ndarray, legend: dict[str, str], target_kind: str, *,
                       margin: float = 0.06) -> dict[str, np.ndarray]:
    """Masks of the regions compared: ``patch:<name>`` (chart), ``disk``, ``open water``.

    Targets' parts lose their edge pixels (:func:`target_masks`); open water is the water farther
    than ``margin`` × the image width from every target pixel (none if fewer than 16 pixels).
    """
    import cv2

    masks = target_masks(object_id, legend, target_kind)
    out = {k: v for k, v in masks.items() if k.startswith("patch:") and v.sum() >= 1}
    if target_kind in ("black-disk", "white-disk") and "signal" in masks:
        out["disk"] = masks["signal"]
    r = max(2, int(round(margin * object_id.shape[1])))
    near = cv2.dilate((object_id > 0).astype(np.uint8), np.ones((2 * r + 1, 2 * r + 1), np.uint8)).astype(bool)
    water = (object_id == 0) & ~near
    if water.sum() >= 16:
        out["open water"] = water
    return out


def _spectral_keys(image, *others) -> list[str]:
    """The spectral layers of ``image`` (that every one of ``others`` has too)."""
    return [k for k in image.layers if (k in SPECTRAL_LAYERS or k.startswith("flash"))
            and all(k in o.layers for o in others)]


def _with_spectra(first, radiance, layers: dict):
    """``first`` with its radiance and spectral layers replaced by ``radiance`` and ``layers`` (a spectral layer
    of its own not among them is dropped; the rest — object ids, range — kept)."""
    spectral = set(_spectral_keys(first))
    return dataclasses.replace(first, radiance=radiance,
                               layers={**{k: v for k, v in first.layers.items() if k not in spectral}, **layers})


def mean_image(images: list):
    """The mean of renders of one scene (:class:`~rigsim.spectral_image.SpectralImage`, same shape): their
    radiance and the spectral layers they all have averaged (a layer some lack is left out), the rest (object
    ids, range, …) the first's."""
    first = images[0]
    keys = _spectral_keys(first, *images[1:])
    return _with_spectra(first, np.mean([np.asarray(i.radiance, float) for i in images], axis=0),
                         {k: np.mean([np.asarray(i.layers[k], float) for i in images], axis=0) for k in keys})


def pooled_metric(images: list, fn) -> tuple[dict, dict]:
    """Scene metrics of independent renders' mean image and their jackknife standard errors (Efron & Stein
    1981; Efron & Tibshirani 1993, ch. 11): ``fn`` (a SpectralImage → dict of numbers) of
    :func:`mean_image`, and ``√((n−1)/n · Σ (θ₍ᵢ₎ − θ₍·₎)²)`` over the ``n`` leave-one-out means (NaN for
    fewer than two renders).

    A metric that is a ratio of region means — the Michelson contrast ``|L_t − L_b| / (L_t + L_b)``, a
    share of the light — is measured on the renders' mean, not averaged over renders: each render's own
    is biased by its noise, the contrast upwards by about ``E|noise|`` (Jerlov 9C, the chart at 3 m, 16
    renders of 64 paths per pixel at 96 × 64, 9 pixels per patch: white against black 0.125 ± 0.025
    averaged over the renders, while the renders' mean patches differ by 0.4 %).
    """
    n = len(images)
    whole = fn(mean_image(images))
    if n < 2:
        return whole, {k: float("nan") for k in whole}
    first = images[0]
    keys = _spectral_keys(first, *images[1:])
    total_r = np.sum([np.asarray(i.radiance, float) for i in images], axis=0)
    total_l = {k: np.sum([np.asarray(i.layers[k], float) for i in images], axis=0) for k in keys}
    loo = [fn(_with_spectra(first, (total_r - np.asarray(i.radiance, float)) / (n - 1),
                            {k: (total_l[k] - np.asarray(i.layers[k], float)) / (n - 1) for k in keys}))
           for i in images]
    se = {}
    for k in whole:
        v = np.array([m.get(k, np.nan) for m in loo], float)
        se[k] = float(math.sqrt((n - 1) / n * np.sum((v - v.mean()) ** 2))) if np.all(np.isfinite(v)) else float("nan")
    return whole, se


#: Fewest regions × colour groups with a fast-engine noise estimate for :func:`moderated_relative_se` to pool them
#: (a chart case has 75; a disk case's 6 are too few to estimate the spread of their variances).
MIN_MODERATED = 10


def moderated_relative_se(rel_se, dof: int) -> np.ndarray:
    """Empirical-Bayes moderated standard errors (Smyth 2004) of many relative standard errors ``rel_se``, each
    from ``dof`` degrees of freedom (the fast engine's photon batches less one).

    With 4 batches each region's noise estimate has 3 degrees of freedom: a third of the true one or less about
    once in 20 regions (χ²₃ < 1/3: 4.5 %), and a fast image that is off by its own noise then reads as a
    disagreement (the edge-lit chart at 6 m in Jerlov II, 2026-12-06: the white patch's 4 batches gave 0.6 % where
    16 seeds of the fast engine scatter by 1.65 %; −5.1 ± 0.7 % read as beyond 3 % + t·SE, over 25 seeds it is
    −1.0 ± 0.4 %).  The regions' variances ``s²`` are taken as draws of a scaled inverse-χ² prior (``d0`` degrees
    of freedom about ``s0²``), fitted by moments of ``log s²`` (Smyth's ``fitFDist``: mean and variance less
    ψ(d/2) and ψ'(d/2)); each is replaced by its posterior mean ``(d0 s0² + d s²)/(d0 + d)`` — shrunk towards the
    case's typical noise as far as the spread of the estimates is more than their own chance spread (all the way
    where it is not: ``d0`` infinite).  Values that are not finite and positive, or fewer than
    :data:`MIN_MODERATED` of them, are returned as they are.

    Smyth, G. K. (2004). Linear models and empirical Bayes methods for assessing differential expression in
    microarray experiments. *Statistical Applications in Genetics and Molecular Biology* 3(1), article 3.
    """
    from scipy.optimize import brentq
    from scipy.special import digamma, polygamma

    r = np.asarray(rel_se, float).copy()
    ok = np.isfinite(r) & (r > 0)
    if dof < 1 or ok.sum() < MIN_MODERATED:
        return r
    s2 = r[ok] ** 2
    e = np.log(s2) - digamma(dof / 2) + math.log(dof / 2)
    excess = float(e.var(ddof=1) - polygamma(1, dof / 2))
    if excess <= 0:  # the estimates scatter no more than their own noise: one common variance
        r[ok] = math.sqrt(math.exp(float(e.mean())))
        return r
    half = brentq(lambda y: float(polygamma(1, y)) - excess, 1e-8, 1e8)  # ψ'(d0/2) = excess
    d0 = 2.0 * half
    s0_2 = math.exp(float(e.mean()) + float(digamma(half)) - math.log(half))
    r[ok] = np.sqrt((d0 * s0_2 + dof * s2) / (d0 + dof))
    return r


def compare_renders(fast, references: list, target_kind: str, *, fast_batches: list | None = None,
                    noise_batches: list | None = None) -> tuple[list[RegionDeviation], list[MetricDeviation]]:
    """Region and metric deviations of a fast-engine render from independent Monte Carlo renders (the contrast
    whatever its size: :func:`chart_beyond_visibility` reads it; tables leave out contrasts below
    :data:`MIN_CONTRAST`).

    Parameters
    ----------
    fast
        :class:`~rigsim.spectral_image.SpectralImage` from :func:`rigsim.preview.render_preview`
        with ``object_id`` (and ``backscatter`` for the share).
    references
        Monte Carlo renders of the same scene, size and bands, independent seeds (at least two).  With
        marine snow the speck share is measured on those with the particles' layer (:func:`rigsim.metrics.specks.has_particle_layer`)
        where not all have it (at least two; else it is not compared).
    target_kind
        The target's kind (which regions and contrast).
    fast_batches
        The fast image made with each batch of its multiple-scattering photons
        (:func:`rigsim.preview.render_photon_batches`, same size; at least two): their spread is the
        fast engine's noise (``fast_se``; over a chart's regions :func:`moderated_relative_se`).  None or empty:
        the fast image is taken as noiseless.
    noise_batches
        The batch images (as ``fast_batches``, as many each) of further fast renders of the scene with other
        seeds, made for the noise estimate alone: each render's batches scatter about their own mean as the
        fast image's do, so their spreads pool with its own — the variance of a region's batch values is the
        pooled within-render variance (``Σ (n − 1)`` degrees of freedom in all, not 3), a metric's the mean of
        the renders' jackknife variances.  The fast image itself stays the one judged.
    """
    if len(references) < 2:
        raise ValueError("the reference needs at least two independent Monte Carlo renders")
    for ref in references:
        if ref.radiance.shape != fast.radiance.shape:
            raise ValueError(f"the renders differ in shape: {ref.radiance.shape} vs {fast.radiance.shape}")
    est = fast_estimates(fast, target_kind, fast_batches=fast_batches, noise_batches=noise_batches)
    h_refs = [r.radiant_exposure(1.0) for r in references]
    n = len(references)
    out: list[RegionDeviation] = []
    for (name, g, px, f, f_se), (m, idx) in zip(est.regions, est.masks):
        per = np.array([h[m][:, idx].mean() for h in h_refs])
        med = float(np.median(per))
        out.append(RegionDeviation(name, g, px, f, float(per.mean()), float(per.std(ddof=1) / math.sqrt(n)),
                                   float(per.max() / med) if med > 0 else float("nan"), f_se))
    mref, ref_se = pooled_metric(references, est.radiance_metrics)
    specked = [r for r in references if has_particle_layer(r)]
    if fast.meta.get("particles") and len(specked) < len(references):
        # marine snow, where only some renders made the particle-free pass (a check's pilot, compute_check): the
        # speck share from those renders alone (the others' mean has no particles' light to measure it on)
        mref.pop("speck_share", None)
        ref_se.pop("speck_share", None)
        if len(specked) >= 2:
            m_p, se_p = pooled_metric(specked, est.radiance_metrics)
            if "speck_share" in m_p:
                mref["speck_share"], ref_se["speck_share"] = m_p["speck_share"], se_p["speck_share"]
    return out, _metric_deviations(est, mref, ref_se)


@dataclass
class FastEstimates:
    """The fast engine's side of a check (:func:`fast_estimates`): each judged region × colour group as
    ``(region, group, pixels, fast, fast_se)`` with its mask and band indices (``masks``: ``(pixels, bands)``),
    the scene metrics of the fast image with their noise (``metrics``: ``{name: (value, se)}``), and the function
    that measures them on any image of the scene (``radiance_metrics``: the fast image's masks)."""

    regions: list
    masks: list
    metrics: dict
    radiance_metrics: object


def fast_estimates(fast, target_kind: str, *, fast_batches: list | None = None,
                   noise_batches: list | None = None) -> FastEstimates:
    """The fast image's region means and scene metrics with their photon noise (the batches as in
    :func:`compare_renders`): what a check compares with its reference, whichever form the reference takes —
    Monte Carlo renders (:func:`compare_renders`) or the numbers a published row kept of them
    (:func:`compare_to_cells`)."""
    fast_batches = list(fast_batches or [])
    nb = len(fast_batches)
    extra = [list(g) for g in noise_batches or []] if nb >= 2 else []  # (no batches of its own: noiseless)
    if any(len(g) != nb for g in extra):
        raise ValueError(f"each render of noise_batches needs as many batch images as fast_batches ({nb})")
    batch_sets = [fast_batches] + extra
    for b in (b for g in batch_sets for b in g):
        if b.radiance.shape != fast.radiance.shape:
            raise ValueError(f"the renders differ in shape: {b.radiance.shape} vs {fast.radiance.shape}")
    dof = len(batch_sets) * (nb - 1) if nb >= 2 else 0  # of the fast engine's noise estimate

    def batch_se(per_group) -> float:
        """Standard error of the fast value from its batch values (one array per render, the judged image's
        first): the pooled within-render variance of a batch value over the judged image's batch count."""
        v = [np.asarray(x, float) for x in per_group]
        if nb < 2 or not all(np.all(np.isfinite(x)) for x in v):
            return 0.0
        ss = sum(float(np.sum((x - x.mean()) ** 2)) for x in v)
        return math.sqrt(ss / dof / nb)

    oid = np.asarray(fast.layers["object_id"])
    regions = comparison_regions(oid, fast.meta.get("object_ids", {}), target_kind)
    groups = colour_groups(fast.wavelength_nm)
    h_fast = fast.radiant_exposure(1.0)
    h_bats = [[b.radiant_exposure(1.0) for b in g] for g in batch_sets]
    est, where = [], []
    for name, m in regions.items():
        for g, idx in groups.items():
            est.append((name, g, int(m.sum()), float(h_fast[m][:, idx].mean()),
                        batch_se([[h[m][:, idx].mean() for h in g] for g in h_bats])))
            where.append((m, idx))
    if nb >= 2:  # each region's noise from `dof` degrees of freedom, moderated over the case's regions
        rel = np.array([e[4] / e[3] if e[3] > 0 else np.nan for e in est])
        mod = moderated_relative_se(rel, dof)
        est = [(*e[:4], float(mod[i] * e[3])) if np.isfinite(mod[i]) and e[3] > 0 else e for i, e in enumerate(est)]
    masks = target_masks(oid, fast.meta.get("object_ids", {}), target_kind)

    def radiance_metrics(si) -> dict:
        m = dict(scene_metrics(si, target_kind, masks=masks)[0])
        if fast.meta.get("particles") and "particle_id" in si.layers:
            from rigsim.metrics.specks import speck_metrics, subject_mask  # marine snow: the specks' share

            m["speck_share"] = speck_metrics(si, subject_mask(masks, target_kind))["speck_share"]
        return m

    mf = radiance_metrics(fast)
    fast_se: dict = {}  # each metric's: the renders' jackknife variances of their batches, pooled
    per_render, weights = [], []
    for g in batch_sets:
        bats = [b for b in g if not fast.meta.get("particles") or "particle_id" in b.layers]
        if len(bats) >= 2:
            per_render.append(pooled_metric(bats, radiance_metrics)[1])
            weights.append(len(bats) - 1)
    for key in set().union(*per_render) if per_render else ():
        v = np.array([x.get(key, np.nan) for x in per_render], float)
        fast_se[key] = float(math.sqrt(np.average(v ** 2, weights=weights))) if np.all(np.isfinite(v)) else float("nan")
    metrics = {k: (float(v), float(fast_se.get(k, 0.0)) if np.isfinite(fast_se.get(k, 0.0)) else 0.0)
               for k, v in mf.items()}
    return FastEstimates(est, where, metrics, radiance_metrics)


def _metric_deviations(est: FastEstimates, mref: dict, ref_se: dict) -> list[MetricDeviation]:
    """The scene metrics of a check: the fast image's (``est``) against the reference's values and SEs."""
    metrics: list[MetricDeviation] = []
    for key in ("contrast_radiance", "backscatter_share", "speck_share"):
        # (a contrast below MIN_CONTRAST is kept here, for chart_beyond_visibility; the study's table leaves it out)
        if key == "speck_share" and not mref.get(key):
            continue
        if key in est.metrics and np.isfinite(mref.get(key, np.nan)):
            f, f_se = est.metrics[key]
            metrics.append(MetricDeviation(key, f, float(mref[key]), float(ref_se[key]), f_se))
    return metrics


def compare_to_cells(fast, cells: list[dict], target_kind: str, *, fast_batches: list | None = None,
                     noise_batches: list | None = None) -> tuple[list[RegionDeviation], list[MetricDeviation]]:
    """A fast image against the reference a published row kept (:func:`read_cells`: one case's cells, the
    reference's mean ``monte_carlo``, its ``monte_carlo_se`` and ``monte_carlo_tail`` per region × colour group
    and per metric): :func:`compare_renders` without the renders, for judging a changed fast engine against the
    references a row was measured with.  Raises ValueError where the fast image's regions are not the cells'
    (another scene, size or region layout: those references do not apply)."""
    est = fast_estimates(fast, target_kind, fast_batches=fast_batches, noise_batches=noise_batches)
    ref = {(c["region"], c["group"]): c for c in cells if c["quantity"] == "radiance"}
    if len(ref) != len(est.regions) or any(ref.get((name, g), {}).get("pixels") not in (str(px), px)
                                           for name, g, px, _, _ in est.regions):
        raise ValueError("the fast image's regions are not the kept cells' (another scene, size or layout)")
    out = [RegionDeviation(name, g, px, f, float(ref[name, g]["monte_carlo"]), float(ref[name, g]["monte_carlo_se"]),
                           float(ref[name, g]["monte_carlo_tail"] or "nan"), f_se)
           for name, g, px, f, f_se in est.regions]
    kept = {c["quantity"]: c for c in cells if c["quantity"] != "radiance"}
    mref = {k: float(c["monte_carlo"]) for k, c in kept.items()}
    ref_se = {k: float(c["monte_carlo_se"]) for k, c in kept.items()}
    return out, _metric_deviations(est, mref, ref_se)


# ---------------------------------------------------------------------------- the published table
@dataclass(frozen=True)
class PublishedAgreement:
    """The benchmark's summary for one water, lighting and rig (``data/fast_engine/agreement.csv``).

    ``worst_deviation`` is the largest fast / Monte Carlo − 1 over the checked regions and colour groups of
    this water with this rig (``worst_where`` says which), ± ``worst_se``; ``cases`` checked cases at
    ``distances_m``; ``beyond`` of ``cells`` region values differed by more than the tolerance plus
    the difference's confidence half-width (:func:`verdict`: the reference's noise and, since the table of
    2026-12-04 evening, the fast engine's own photon noise; the tables before counted the reference's alone).
    ``rig`` is the shipped rig the cases used.
    """

    lighting: str
    water: str
    cases: int
    distances_m: str
    worst_deviation: float
    worst_se: float
    worst_where: str
    tolerance: float
    beyond: int
    cells: int
    measured: str
    settings: str
    rig: str
    engine: str = ""  #: the fast engine measured ("commit 692f13b", "-dirty" if it differed); "" in rows before 2026-12-06
    #: chart cells of cases beyond the chart's visibility (listed, not judged; :func:`chart_beyond_visibility`);
    #: None in rows judged before the rule (every cell judged)
    beyond_visibility: int | None = None

    def sentence(self, rig: str | None = None) -> str:
        """One line for a user: how far the fast engine's picture of this water is from Monte Carlo.

        ``rig``: the rig the user looks at; if it is not the one measured, the line says so."""
        tail = (f"; {self.beyond} of {self.cells} region values beyond ±{self.tolerance:.0%} by more than the "
                f"reference's noise" if self.beyond else f", all within ±{self.tolerance:.0%} or the reference's noise")
        if self.worst_se > self.tolerance:  # "within noise" then says little: say so
            tail += (f"; the Monte Carlo reference is too noisy there (± {self.worst_se:.0%}) to show agreement "
                     f"within ±{self.tolerance:.0%}")
        if self.beyond_visibility:
            tail += f" ({self.beyond_visibility} chart cells where the chart cannot be seen not judged)"
        other = f" (not checked with {rig}: these numbers are the {self.rig} rig's)" if rig and rig != self.rig else ""
        engine = f" (fast engine of {self.engine})" if self.engine else ""
        was = re.search(r"fast images identical to those of (commit \w+)", self.settings or "")
        if was and self.engine:  # a row restamped by --verify-unchanged: measured by the earlier engine
            engine = f" (fast engine of {was[1]}; {self.engine} makes the same images)"
        return (f"fast engine vs Monte Carlo in {self.water} ({self.lighting}, {self.rig}, {self.cases} cases at "
                f"{self.distances_m} m): worst region {self.worst_deviation:+.1%} ± {self.worst_se:.1%} "
                f"({self.worst_where}){tail} — measured {self.measured}{engine}{other}")


#: The published summary (in ``data/``): written by ``benchmarks/bench_fast_engine_agreement.py --publish``.
PUBLISHED_TABLE = "fast_engine/agreement.csv"


def _distances_text(v) -> str:
    """The ``distances_m`` column as written ("1, 3"; a single distance is read back as a number)."""
    return f"{float(v):g}" if isinstance(v, (int, float, np.floating)) else str(v)


def distance_set(text: str) -> set[float]:
    """The distances (m) of a ``distances_m`` entry ("0.5, 1, 3")."""
    try:
        return {float(x) for x in str(text).split(",") if x.strip()}
    except ValueError:
        return set()


def published_agreement(water_name: str, lighting: str = "strobes", rig: str | None = None) -> PublishedAgreement | None:
    """The benchmark's summary for a water (None if the benchmark did not measure it).

    With ``rig``, that rig's row if the benchmark checked it (of its rows at different distances, the one whose
    worst region is farthest from Monte Carlo); otherwise (or without ``rig``) the water's row
    whose worst region is farthest from Monte Carlo over the rigs it checked — the cautious answer for a rig
    it did not."""
    from rigsim.data import DATA_DIR, read_csv_table
    from rigsim.errors import DataError

    try:
        t = read_csv_table(DATA_DIR / PUBLISHED_TABLE)
    except (OSError, DataError):
        return None
    if "rig" not in t.columns:  # a table of the layout before 2026-12-05 (summed over rigs): not trusted
        return None
    cols = t.columns
    engines = cols.get("engine")
    if engines is None or engines.dtype.kind != "U":  # no column, or only blank cells (read as NaN)
        engines = [""] * len(cols["water"])
    unseen = cols.get("beyond_visibility")

    def _count(i):  # blank (a row judged before the rule) or no column: None
        if unseen is None:
            return None
        try:
            v = float(unseen[i])
        except (TypeError, ValueError):
            return None
        return int(v) if math.isfinite(v) else None

    found = []
    for i in range(len(cols["water"])):
        if cols["water"][i] == water_name and cols["lighting"][i] == lighting:
            found.append(PublishedAgreement(
                lighting=str(cols["lighting"][i]), water=str(cols["water"][i]), cases=int(cols["cases"][i]),
                distances_m=_distances_text(cols["distances_m"][i]), worst_deviation=float(cols["worst_deviation"][i]),
                worst_se=float(cols["worst_se"][i]), worst_where=str(cols["worst_where"][i]),
                tolerance=float(cols["tolerance"][i]), beyond=int(cols["beyond"][i]), cells=int(cols["cells"][i]),
                measured=str(cols["measured"][i]), settings=str(cols["settings"][i]),
                rig=str(cols["rig"][i]), engine=str(engines[i]), beyond_visibility=_count(i)))
    same = [p for p in found if rig and p.rig == rig]  # the rig's rows (one per distance set): the worst of them
    return max(same or found, key=lambda p: abs(p.worst_deviation), default=None)


#: Columns of a published row's cells file (:func:`write_published`, ``cells_dir``): every cell the row's run
#: compared (the study's ``agreement.csv`` columns that say what and how well), radiance cells and metrics alike.
CELL_COLUMNS = ("lighting", "rig", "water", "target", "distance_m", "tolerance", "width", "height", "spp", "seeds",
                "reference", "quantity", "region", "group", "pixels", "fast", "monte_carlo", "monte_carlo_se",
                "fast_se", "deviation", "deviation_se", "monte_carlo_tail", "verdict")


def cells_file_name(lighting: str, water: str, rig: str, distances_m: str) -> str:
    """The file of one published row's cells: ``strobes__jerlov-II__twin-strobes-45-wide__0.5-1-3-6.csv.gz``."""
    return f"{lighting}__{water}__{rig}__{distances_m.replace(', ', '-')}.csv.gz"


def _cell_text(v) -> str:
    """A cell's value as written: whole numbers as they are, other numbers to 6 significant digits (the cells'
    own noise is far above that), text as it is."""
    if v is None:
        return ""
    if isinstance(v, (bool, int, np.integer)):
        return str(v)
    if isinstance(v, (float, np.floating)):
        return f"{float(v):.6g}"
    text = str(v)
    try:
        f = float(text)
    except ValueError:
        return text
    return text if text.strip().lstrip("-").isdigit() else f"{f:.6g}"


def write_cells(path, rows: list[dict], *, header: str = "") -> None:
    """Write one published row's cells (:data:`CELL_COLUMNS`) to ``path``, gzip-compressed and atomically, with
    ``header`` as ``#`` comment lines (what made them).  The bytes depend only on the contents (no time stamp)."""
    import csv
    import gzip
    import io

    from rigsim.fileio import atomic_write_bytes

    buf = io.StringIO()
    for line in header.splitlines():
        buf.write(f"# {line}\n")
    wr = csv.DictWriter(buf, fieldnames=list(CELL_COLUMNS), lineterminator="\n", extrasaction="ignore")
    wr.writeheader()
    for r in rows:
        wr.writerow({c: _cell_text(r.get(c, "" if c != "lighting" else "strobes")) for c in CELL_COLUMNS})
    atomic_write_bytes(path, gzip.compress(buf.getvalue().encode(), mtime=0))


def read_cells_header(path) -> list[str]:
    """The ``#`` lines heading a cells file (:func:`write_cells`), without the ``# ``."""
    import gzip

    out = []
    with gzip.open(path, "rt") as fh:
        for line in fh:
            if not line.startswith("#"):
                break
            out.append(line[1:].strip())
    return out


def read_cells(path) -> list[dict]:
    """The cells of one published row (:func:`write_cells`), as text fields."""
    import csv
    import gzip

    with gzip.open(path, "rt", newline="") as fh:
        return list(csv.DictReader(ln for ln in fh if not ln.startswith("#")))


def write_published(rows: list[dict], path, *, settings: str, engine: str = "", cells_dir=None,
                    cells_header: str = "", current: Callable[[dict], bool] | None = None) -> None:
    """Write the per-lighting, per-water, per-rig, per-distance-set summary of agreement rows (``agreement.csv``
    of studies, plus a ``lighting`` column; ``cells`` counts the judged cells, ``beyond_visibility`` the chart cells
    of cases beyond the chart's visibility, left out of ``worst_*`` and ``beyond``; blank in rows from before
    2026-12-06) to ``path`` (atomically), keeping the other waters, rigs and distance
    sets already there — a run at 0.5 and 6 m adds rows beside the 1 and 3 m ones; a row whose distances are all
    in a new row's is replaced by it (rows of the older tables without a ``rig`` column, which summed over rigs,
    are dropped).  ``engine``: which fast engine was measured (the benchmark writes the checkout's commit,
    ``"commit 692f13b"``, with ``-dirty`` if the package differed from it), so a reader sees which rows a later
    change of the engine has not re-made.

    ``cells_dir``: also write each new row's every cell there (:func:`write_cells`, :func:`cells_file_name`;
    ``cells_header`` says what made them) and remove the cells of the rows it supersedes: the table's numbers
    with what they came from, cell by cell (the fast and reference values, each one's standard error, the
    reference's tail), which a later change of the fast engine can be judged against.

    ``current``: which rows already in the table are the measuring engine's own (the benchmark's test of a row's
    ``engine``).  A row that is not (an earlier engine's) is also dropped once the new row and the table's current
    rows of the same lighting, water and rig cover its distances between them: a stale row can then be re-made one
    distance at a time, each run short enough to finish, and goes when its last distance is in."""
    import datetime
    from collections import defaultdict
    from pathlib import Path

    path = Path(path)
    old = read_published(path)
    by = defaultdict(list)
    for r in rows:
        if r["quantity"] == "radiance":
            by[(r.get("lighting", "strobes"), r["water"], r["rig"])].append(r)
    today = datetime.date.today().isoformat()
    for (light, water, rig), every in by.items():
        rs = [r for r in every if judged(r)] or every  # (a water whose every cell is unjudged: shown, none beyond)
        w = max(rs, key=lambda r: abs(float(r["deviation"])))
        cases = {(r["rig"], r["target"], float(r["distance_m"])) for r in every}
        dist = ", ".join(f"{d:g}" for d in sorted({c[2] for c in cases}))
        covered = {c[2] for c in cases}
        fresh = covered | {d for k, r in old.items() if k[:3] == (light, water, rig) and current is not None
                           and current(r) for d in distance_set(k[3])}
        for key in [k for k in old if k[:3] == (light, water, rig) and (
                distance_set(k[3]) <= covered or
                (current is not None and not current(old[k]) and distance_set(k[3]) <= fresh))]:
            del old[key]  # superseded: its distances are all in the new row (or, an earlier engine's, re-made)
            if cells_dir is not None:
                (Path(cells_dir) / cells_file_name(*key)).unlink(missing_ok=True)
        if cells_dir is not None:
            Path(cells_dir).mkdir(parents=True, exist_ok=True)
            write_cells(Path(cells_dir) / cells_file_name(light, water, rig, dist),
                        sorted(every, key=lambda r: (r["target"], float(r["distance_m"]))) +
                        [r for r in rows if r["quantity"] != "radiance" and
                         (r.get("lighting", "strobes"), r["water"], r["rig"]) == (light, water, rig)],
                        header=f"{light}, {water}, {rig}, {dist} m: measured {today}, {engine or 'engine not recorded'}"
                               f"\n{settings}" + (f"\n{cells_header}" if cells_header else ""))
        old[(light, water, rig, dist)] = {
            "lighting": light, "water": water, "rig": rig, "cases": len(cases), "distances_m": dist,
            "worst_deviation": f"{float(w['deviation']):.4f}", "worst_se": f"{float(w['deviation_se']):.4f}",
            "worst_where": f"{w['region'].replace('patch:', '')}, {w['group']}, {w['target']} at "
                           f"{float(w['distance_m']):g} m",
            "tolerance": w["tolerance"], "beyond": sum(r["verdict"] == "disagrees" for r in rs),
            "cells": sum(judged(r) for r in every), "beyond_visibility": sum(not judged(r) for r in every),
            "measured": today, "engine": engine, "settings": settings}
    _write_published_table(path, old)


#: The published table's columns (:func:`write_published`).
PUBLISHED_COLUMNS = ("lighting", "water", "rig", "cases", "distances_m", "worst_deviation", "worst_se", "worst_where",
                     "tolerance", "beyond", "cells", "beyond_visibility", "measured", "engine", "settings")


def read_published(path) -> dict[tuple[str, str, str, str], dict]:
    """The published table's rows (:func:`write_published`) by (lighting, water, rig, distances_m); {} if none."""
    import csv
    from pathlib import Path

    path = Path(path)
    if not path.is_file():
        return {}
    with open(path, newline="") as fh:
        lines = [ln for ln in fh if not ln.startswith("#")]
    return {(r["lighting"], r["water"], r["rig"], r["distances_m"]): r for r in csv.DictReader(lines) if r.get("rig")}


def _write_published_table(path, table: dict) -> None:
    """Write the rows ``table`` (key → row, :func:`read_published`) as the published table, atomically."""
    import csv
    import io
    from pathlib import Path

    from rigsim.fileio import atomic_write_text

    path = Path(path)
    buf = io.StringIO()
    buf.write("# The fast engine against Monte Carlo, per water and rig: benchmarks/bench_fast_engine_agreement.py "
              "--publish\n"
              "# (rigsim.metrics.agreement); deviations are fast / Monte Carlo - 1 of region means (fractions)\n")
    wr = csv.DictWriter(buf, fieldnames=list(PUBLISHED_COLUMNS), lineterminator="\n")
    wr.writeheader()
    for key in sorted(table):
        wr.writerow({c: table[key].get(c, "") for c in PUBLISHED_COLUMNS})
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(path, buf.getvalue())


def restamp_published(path, stamps: dict[tuple[str, str, str, str], tuple[str, str]]) -> int:
    """Give rows of the published table another engine: ``stamps`` maps a row's key (:func:`read_published`) to
    ``(engine, note)``; the row's ``engine`` becomes ``engine`` and ``note`` is added to its ``settings`` (its numbers
    and ``measured`` date stay).  For rows whose fast images a later engine was shown to make bit for bit
    (``bench_fast_engine_agreement.py --verify-unchanged``): the same measurement, of that engine too.  Returns the
    rows changed."""
    table = read_published(path)
    n = 0
    for key, (engine, note) in stamps.items():
        row = table.get(key)
        if row is None:
            continue
        row["engine"] = engine
        row["settings"] = f"{row.get('settings', '')}; {note}" if row.get("settings") else note
        n += 1
    if n:
        _write_published_table(path, table)
    return n
