"""Multiply scattered light for the fast engine: a spectral photon tracer at low resolution.

The analytic image model (:mod:`rigsim.preview.model`) carries every path with at most one
wide-angle scattering: light that reaches the target with only small-angle (< ψ_c) scatterings
on the way (direct and small-angle-blurred, both legs) and light scattered once by more than ψ_c
into the camera (quasi-single scattering, :mod:`rigsim.preview.backscatter`).  Everything else —
light scattered by more than ψ_c twice or more, light that reaches the target after a wide-angle
scattering, light reflected by a target and then scattered into the camera, inter-reflections —
is what this module estimates ("class B").  In turbid water it is the glow of the veil and the
diffuse light on the target; it is smooth in the image and in range, so it is computed by Monte
Carlo at low resolution and added to the analytic full-resolution image.

Estimator
---------
Photons leave the lights (a light chosen ∝ its power, a direction ∝ its beam pattern), travel
by free flights through the water, scatter by the water's own phase function
(:mod:`rigsim.scene.phase_tables`) and reflect diffusely off the targets
(:mod:`rigsim.preview.geometry`).  Each photon carries all bands at once (spectral MIS over
whole paths, as the renderer's integrator: a hero band ``h`` drawn once per photon drives the
free flights and the scattering angles; the weight of band λ is ``f_λ / mean_j p_j`` over the
densities the path would have had with every other hero, so no band's weight is unbounded).

* **Veil** — the light scattered towards the camera, ``w_λ b_λ p_λ(ψ) e^{−κ_λ s} / s²`` per unit
  length of a photon's flight (``s`` the distance to the entrance pupil), is splatted into the
  low-resolution pixel that sees the point (:func:`rigsim.scene.optics.project_points`) and the
  range bin of ``s``, divided by the cell's solid angle: radiance.  The cumulative sum over range
  bins is read at each full-resolution pixel's own range (so the veil in front of a target stops at
  the target; no occlusion test is needed).  Outside the near zone (:data:`NEAR_ZONE_M` about the
  pupil) every flight after a significant event scores along its length (the track-length
  estimator, with points drawn equiangularly about the pupil so the ``1/s²`` cancels:
  :func:`_splat_track`); inside it, the veil is gathered by a flight aimed at the zone from every
  scattering vertex and surface hit, integrated with exact transmittance (:func:`_splat_near`).
  The plain collision estimator (a splat at each vertex, ``track_points=0``) scores the water next
  to the port only where a photon happens to scatter there: in an edge-lit Jerlov 3C scene a
  quarter of the class-B veil came from 72 vertices, and the veil's batch noise was 17 % at 200 000
  photons; with these estimators it is 2–3 % at 100 000 (1.2 % in a ``twin-strobes-45-wide``
  scene), for about the same time.
* **Targets** — a class-B photon that reaches a target deposits its flux in a cell of the
  surface's texture (irradiance, W/m²); the fast engine lights the target with it (``ρ/π E``, seen
  through the water like the target's direct light).  On a flat target of several pieces (a
  ColorChecker's 24 patches) the cells of all its pieces are pooled by a local-quadratic regression
  over its plane (:data:`TARGET_KERNEL_M`, a kernel on the target as :data:`KERNEL_M` is one in the
  water): a patch's own cells hold a twenty-fifth of the chart's photons, and in Jerlov 3C at 1 m their
  noise had put a patch 9 % below Monte Carlo (light skin, −9.3 ± 2.1 %; over 16 seeds of the fast engine
  −4.6 ± 1.9 %).  Every scattering vertex also sends a flight to a point on the targets (class-B connections
  only), combined with the hits by the balance heuristic (:class:`_SurfaceNEE`): a chart far off in clear water
  is met by few photons after a wide-angle scattering, and its patches' light carried their noise.  Measured
  2026-12-07 (96×64, seeds of 98 304 photons, flights against hits alone): edge-lit chart at 6 m in Jerlov II,
  the white patch's spread between 6 seeds 2.0 / 2.1 / 1.1 → 0.9 / 0.7 / 0.4 % (blue / green / red), the chart's
  mean over 12 seeds −0.01 %; at 6 m in coastal water with marine snow (the demo's cell that had been beyond
  tolerance; 10 seeds) the blue flower's blue 2.3 → 1.3 %, the chart's mean −0.27 %; in Jerlov 9C at 1 m and 5C
  at 3 m (the veil in front of a patch holds most of its noise) the median spread 1.42 → 1.45 and 1.50 → 1.65 %,
  the chart's mean +0.19 ± 0.3 and −0.15 ± 0.4 % (40 and 24 seeds); the engine's time +10–15 % at 640×427 where it traces.  Over the 16 agreement rows that keep their
  cells the fast engine's own noise fell from 0.5 / 1.1 % (median / 90th percentile of a cell) to 0.3 / 0.8 %.
* **Path classes** — a path is class A (left to the analytic model) while it has no scattering by
  more than ψ_c and no surface: its surface hit, and its vertices whose scattering towards the
  camera is by more than ψ_c, are not counted; every other vertex and surface hit is.  Every path
  of the full transport is counted exactly once, by the analytic model or here.
* Russian roulette (survival ∝ the path's largest band weight times the camera leg's transmittance
  from beyond :data:`ROULETTE_FREE_M`, :func:`roulette_importance`) ends weak and far-away photons;
  photons farther than 30 attenuation lengths of the clearest band from the camera end.

The estimate is unbiased for class B but for the approximations below; its noise falls as
1/√photons and is measured from independent batches (:attr:`MultipleScattering.relative_noise`).
Where the default photons leave the class-B light's noise above :data:`NOISE_TARGET` of the image's light
(:func:`rigsim.preview.model.class_b_noise`), the fast engine traces up to :data:`MAX_PHOTON_FACTOR` times as many,
of another stream of the same seed (:func:`photon_factor`, :meth:`MultipleScattering.merged`).  The number of
photons then depends on the first ones' noise; over 12 seeds of an edge-lit chart in Jerlov 7C at 1 m (2-4 times
the photons) its mean differed from the fixed photons' by −0.17 ± 0.4 % (blue): no bias seen.

* **Spectral nodes** — photons carry :data:`SPECTRAL_NODES` wavelengths per unit of each light's
  power; the result is interpolated to the bands and multiplied by the lights' spectra.
* **δ-truncation** — scatterings by less than ψ_c are no scattering on the photons' way
  (``truncate_rad``), which cuts the collisions per photon about five-fold in Jerlov 3C; they come back
  as turns of the photons' directions along the flights (:class:`ConeTurns`), which are not vertices.
  Without the turns the class-B veil was 6-7 % low in the edge-lit rig in Jerlov 7C and 9C (many turns of
  5-30 deg add up to wide ones; the truncation keeps ``b (1 − F)`` but not the transport coefficient
  ``b (1 − g)``, of which in 9C the cone holds 16 %).
* **Kernel in the water** — each range bin of the veil is blurred across the image by
  :data:`KERNEL_M` at its distance (a density estimate over decimetres of water, not over a
  cell's frustum, which near the port holds few photons).

Status (2026-12-04): on by default where the water scatters widely (``multiple="auto"``).  The demo
(``studies/demo.toml``, 640×427, 100 000 photons per case, up to 400 000 where their noise asks: four cases) runs in 7.5–11 min on 2 cores (README) and its
Monte Carlo checks agree within tolerance (or within the references' noise) in every water it contains.  Where
the fast engine still falls short, measured in the worst water (Jerlov 9C, ``twin-strobes-45-wide``,
open water without a target, bands 450/550/650 nm, 32 Monte Carlo renders, 16 seeds of the fast
engine; fractions of Monte Carlo's veil):

* fast engine 0.974 / 0.976 / 0.984 (±0.010 / 0.006 / 0.005) = analytic class A 0.628 / 0.665 / 0.744
  + class B 0.346 / 0.311 / 0.240;
* the same paths by this tracer (every estimator exact: collision estimator, every band, no
  δ-truncation, no kernel): class A 0.650 / 0.681 / 0.758 (±0.004), class B 0.340 / 0.311 / 0.239
  (±0.005), all at once (``classes="qss"``) 0.989 / 0.992 / 0.997 (±0.006).  The class-B estimators
  above (track length, near zone, δ-truncation, kernel) agree with the exact ones to < 1 % of the
  veil; the deficit is the analytic model's class-A veil, 2.2 / 1.6 / 1.4 % of the veil low (97.5 %
  of its traced paths at 450 nm, ``benchmarks/bench_fast_engine_split.py``), most in the image centre
  (0.92–0.95 of the traced class A there), from the water within 0.4 m of the port, lit by the edges
  of the strobes' beams.  With a chart at 1 m the open water around it reads 0.945 / 0.968 / 0.976
  (analytic A 2 % of the veil below its traced paths; class B ±1.8 %).  Since then (2026-12-06) the
  analytic class A has the turns of both legs (:data:`rigsim.preview.model.SPREAD_PHASE`,
  :data:`~rigsim.preview.model.SPREAD_CAMERA_LEG`): against Monte Carlo's class-A light (renders split by
  class, ``benchmarks/bench_fast_engine_classes.py``) 1.002 / 1.003 / 1.001 here at 1 m, and the whole veil
  0.988 / 0.988 / 0.994.
* ψ_c moves the answer although it should not: 20° / 25° / 30° / 45° give −2.9 / −3.4 / −6.0 / −9.2 %
  (blue, the chart's open water in 9C) and in Jerlov 5C 20° overshoots (+3.3 % red against −0.2 % at
  30°): no single cut-off is right in both, so ψ_c stays 30°.
* the kernel in the water (:data:`KERNEL_M`) trades a bias for noise.  Uncapped, near the port it
  was tens of cells wide: it flattened each near bin's veil over the image and lost part of it off the
  image's edges.  The open water around a chart (fast / Monte Carlo − 1, blue / green / red, 16 seeds):
  Jerlov 7C at 3 m −6.5 / −3.7 / −2.9 % with it, −4.6 / −2.6 / −2.0 % without; 9C at 1 m −5.5 / −3.2 /
  −2.4 % (±1.8 %) and −4.0 / −2.7 / −2.4 % (±0.8 %); III at 3 m −1.1 and −0.5 %; 5C at 1 m −2.7 / −0.6 /
  −0.1 % and −2.3 / −1.4 / −1.3 %.  Without it the class-B noise of a pixel, over seeds, is 9 % (median;
  90th percentile 18 %) of the pixel's value in 9C at 1 m and 7 % (14 %) in 7C at 3 m, against 6 % (8 %)
  and 2 % (4 %) with it: blotches in the photograph.  So it stays, at most 1.5 cells wide
  (:data:`KERNEL_MAX_CELLS`, with the measurements that chose it): most of the bias goes, and the noise
  falls too.
* the class-B light is itself Monte Carlo: in 9C at 1 m its region mean varies 7–10 % (coefficient of
  variation between seeds of 100 000 photons), 2–3 % of the blue veil, with an occasional seed far
  above (+19 % of the veil once in 24: a scattering vertex within 0.2 m of the port).  The
  agreement check's standard error is the reference's alone.  A study measures what this noise does
  to its contrasts and visibility ranges (:attr:`MultipleScattering.batches`,
  :func:`rigsim.preview.model.render_photon_batches`): where a chart is seen through a heavy veil it
  dominates — the edge-lit ColorChecker of the demo in Jerlov 3C at 6 m has a white-against-black
  contrast of 0.012 ± 0.007; with only the veil's batches varying its standard error was 0.007, with
  only the targets' class-B irradiance 0.0025 (96×64, one seed): the veil in front of the two patches
  (they lie in different cells of the grid), whose difference is the contrast.

The agreement benchmark (``twin-strobes-45-wide``, 1 and 3 m, ``data/fast_engine/agreement.csv``;
re-published 2026-12-05 with every render kept and, where the first 4 leave a region noisy, up to 1 024 Monte Carlo
renders for strobes and daylight's to 0.75 %, the smoothing on the targets, the daylight's sub-band reflectances and
the spread directions of the beam's forward-scattered light, :meth:`rigsim.preview.forward.SmallAngle.spread_beta`):
0 of 8 149 cells beyond tolerance + t·SE.  The day before (up to 256 renders, no smoothing on the targets) 3 had been:
Jerlov 3C at 1 m, light skin, blue −9.3 ± 2.1 % (the fast engine's photon noise on one patch: over 16 seeds −4.6 ±
1.9 %; with :data:`TARGET_KERNEL_M` −5.1 ± 2.0 %); 9C at 1 m, neutral 5, blue +14.3 ± 3.9 % (256 renders; +8.3 ±
3.7 % against 1 024); Jerlov IB at 15 m depth, green patch at 3 m, red +6.5 ± 1.5 % against 23 renders (+0.9 ± 0.8 %
against 92).  Still, 87 cells are beyond their tolerance within the reference's noise, 50 of them with a standard
error above 3 %: the chart patches of Jerlov III and 5C–9C, whose references stay heavy-tailed (one render up to 240×
the median after 1 024).  Before (16 renders, 2026-12-04 evening) 31 of
7 776 radiance cells had been beyond, 27 of them chart patches brighter in the fast engine (+10 … +37 %) on
heavy-tailed references: with 64 renders 7 of those were left, with 256 none — the references had not converged
(Jerlov III at 3 m: blue patch +10.1 ± 2.5 → +5.8 ± 2.0 %, orange +7.9 ± 1.8 → −2.0 ± 2.5 %, purple +6.3 ± 1.5 →
+0.2 ± 2.3 %), as the light-traced reference (``benchmarks/bench_reference_hybrid.py``: within −7 … +6 %, median
−0.1 %, of Monte Carlo in coastal water; the fast engine's chart of the table's 9C case at 1 m −0.3 %, median of its
72 patch cells) had said.  The open water of 9C around a black disk at 1 m went from −7.0 ± 0.7 to −4.0 ± 0.7 % and
of 7C around a chart at 3 m from −5.8 ± 0.4 to −3.7 ± 0.4 % (blue) with the spread directions.
The four other strobe rigs (2026-12-05, all 16 waters at 1 and 3 m, 4–32 renders; a row per rig in the table): 43 of
10 870 cells beyond tolerance + t·SE, all chart cells of cases whose reference is heavy-tailed but one contrast near
the floor; the open water within 5 % everywhere but with the edge-lit rig in 5C, 7C and 9C (−5 … −15 % ± 3–11 %,
blue and green, within the noise of references that are noisy there; 9C at 3 m −8.6 ± 2.3 % blue with 64 renders,
−4.2 ± 2.3 % at 450 nm against 32 other renders), whose parts the split benchmark finds right
(``benchmarks/bench_fast_engine_split.py --rig twin-strobes-edge-lighting``).
Before the spread directions the fast engine's veil was low where the strobes' beams are (the image's sides)
and a little high between them (with them, in 9C around the disk at 1 m, blue, by column group left → right
0.94 / 0.96 / 1.02 / 0.97 / 0.98 of 40 Monte Carlo renders, from 0.91 / 0.93 / 1.00 / 0.95 / 0.95): in 9C at 1 m and 7C at 3 m by image column 0.91–0.92 of Monte Carlo at the sides,
1.02–1.04 in the middle; the analytic class A alone is 0.95–0.98 of its traced paths at the sides (two runs)
(``benchmarks/bench_fast_engine_split.py``).  Most of it is class B's, and it is the 16-cell grid
and its kernel, not the estimators: in 9C open water (450 nm, 48 x 32, fractions of the every-path veil)
the default class B holds 0.25 / 0.28 in the outer 4-pixel columns (left / right) on its 16-cell grid;
on a 48-cell grid, over 4 seeds of 200 000 photons (outer 6-pixel columns, ± standard error), the
default estimators hold 0.287 / 0.284 (± 0.015 / 0.019), the collision estimator with δ-truncation
0.293 / 0.288 (± 0.008 / 0.011) and the exact ones (no δ-truncation, collision estimator) 0.299 / 0.299
(± 0.005 / 0.004); the middle columns agree too (0.38–0.44).  (Single seeds had suggested the estimators
lost 0.03–0.06 at the edges: it was their noise.)  The veil rises steeply towards the sides, and a
1.5-cell kernel with ``mode="nearest"`` on 16 cells averages lower inside values into the edge cells (a
local-linear smoother, tried, won 0.02 of the 0.09; a finer grid costs noise: 48 cells gave nine times
the cells' noise).  Measured 2026-12-04 at the checks' 96 × 64 (9C, 450 nm, 6 seeds of 100 000 photons,
outer 12-pixel columns left / right, against 0.306 / 0.301 of the exact estimators on 48 cells, 4 seeds): 16 cells
0.267 / 0.292, 24 cells 0.275 / 0.299, 32 cells 0.278 / 0.302, for a pixel noise (median over pixels of
the spread over seeds / the mean) of 7.4 / 9.6 / 12.5 %; the grid stays at 16.  Interpolating linearly
past the outer cells' centres instead of holding their value changed the outer columns by < 0.001.  The
beam's small-angle blur keeps the beam's power (on the sphere, within 0.4 % at 1 m and 1.4 % at 3 m in
9C), so it is not that.  Since 2026-12-04 the grid goes :data:`GRID_PAD` cells beyond the image, so the kernel
no longer averages the edges with copies of themselves: outer 12-pixel columns 4.10 / 4.03 → 4.24 / 4.24
(exact estimators 4.43 / 4.43; same units and seeds as at :data:`GRID_PAD`).  What is left at the sides, measured
the same day (Jerlov 9C, black disk at 1 m filling 0.4 of the width, open water, 40 Monte Carlo renders of 64
paths per pixel at 96 × 64 against one fast image): fast / Monte Carlo − 1 by 12–24-pixel column groups
(blue bands, left → right) −9.8 ± 1.6, −7.7 ± 0.9, −5.9 ± 1.6, −0.4 ± 1.6, −3.0 ± 1.3, −6.2 ± 0.8,
−5.5 ± 0.8 %; by band −11 % at 400 nm, −5 to −8 % 410–490 nm, −4 % green, −2 to −3.5 % red.  Its parts
(450 nm, open water without the disk, outer 12-pixel columns): the analytic class A 2.6 % below its traced
paths (2.2 % over the image; not the quadrature — 64, 256, 1 024 nodes agree to 1e-4 — nor the coarse grid
of rays), class B 4 % below the exact estimators (a 48-cell grid: 2 %), and the quasi-single camera leg
about 1 %: each a few percent of the veil, together most of it.

References
----------
Jensen, H. W. (2001). *Realistic Image Synthesis Using Photon Mapping* (particle tracing, the
collision estimator).  Veach, E. (1997). *Robust Monte Carlo Methods for Light Transport
Simulation*, PhD thesis, Stanford (light tracing to the camera, §10.2).  Wilkie, A. et al.
(2014). Hero wavelength spectral sampling. *Computer Graphics Forum* 33(4).  Jensen, H. W. &
Christensen, P. H. (1998). Efficient simulation of light transport in scenes with participating
media using photon maps. *SIGGRAPH '98* (the kernel in the water).  Wiscombe, W. J. (1977). The
delta-M method. *J. Atmos. Sci.* 34, 1408 (the δ-truncation).  Spanier, J. & Gelbard, E. M.
(1969). *Monte Carlo Principles and Neutron Transport Problems*, Addison-Wesley (the track-length
estimator).  Kulla, C. & Fajardo, M. (2012). Importance sampling techniques for path tracing in
participating media. *Computer Graphics Forum* 31(4) (equiangular sampling).  Jarosz, W., Nowrouzezahrai,
D., Sadeghi, I. & Jensen, H. W. (2011). A comprehensive theory of volumetric radiance estimation using
photon points and beams. *ACM Trans. Graph.* 30(1) (a flight's light gathered along it).
"""

from __future__ import annotations

import dataclasses
import hashlib
import time
from dataclasses import dataclass

import numpy as np

from rigsim.light.beam import beam_solid_angle_sr, local_to_world, sample_beam_direction
from rigsim.preview.geometry import SceneSurfaces, cast_rays, occluded
from rigsim.scene.optics import cell_solid_angles, outside_index, port_reach_m, project_points
from rigsim.scene.phase_tables import PhaseTables
from rigsim.scene.surfaces import disk_cell_fraction
from rigsim.scene.types import Scene
from rigsim.spectrum import band_average, band_edges
from rigsim.water.particles import lambert_sphere_phase

__all__ = ["MultipleScattering", "trace_multiple", "default_photons", "photon_factor", "DEFAULT_PHOTONS", "DEFAULT_GRID",
           "NOISE_TARGET", "MAX_PHOTON_FACTOR"]

#: Photons per light group (all bands at once) of an image of 6 250 pixels or more (96×64 and up).
DEFAULT_PHOTONS = 100_000
#: Fewest photons of a thumbnail (:func:`default_photons`).
MIN_PHOTONS = 20_000


def default_photons(width: int, height: int) -> int:
    """Photons for an image: 16 per pixel between :data:`MIN_PHOTONS` and :data:`DEFAULT_PHOTONS`
    (the tracer's time does not depend on the image size; a thumbnail of a few hundred pixels
    does not pay two seconds for it, a check image of 96×64 and a photograph get the full count)."""
    return int(np.clip(16 * int(width) * int(height), MIN_PHOTONS, DEFAULT_PHOTONS))
#: The class-B light's own photon noise the fast engine keeps below: the 90th percentile over the image's pixels
#: (:func:`rigsim.preview.model.class_b_noise`) of its standard error over the image's light, in the worst colour
#: group — at most the agreement tolerance with Monte Carlo (5 %, :mod:`rigsim.metrics.agreement`).  Where the default
#: photons leave it above this, more are traced (up to :data:`MAX_PHOTON_FACTOR` times as many, :func:`photon_factor`).
#: Measured 2026-12-08 with the default photons (the demo's 96 cases at 640 x 427, ``studies/demo.toml``, seed 1): clear
#: water 0.3-1.2 % with the strobes beside the port, 1.3-2.8 % edge-lit; coastal water with marine snow 0.6-1.0 % and
#: 2.0-6.3 %; Jerlov 3C 1.0-1.5 % and 3.0-6.0 % (a ColorChecker at 3-6 m); coastal-regions none (no class B).  Jerlov 7C,
#: edge-lit, a chart at 0.5 and 1 m (96 x 64): 5.2 and 5.1 %, and with four times the photons 3.7 and 2.6 %.  On a
#: patch of 9-12 pixels the spread between seeds is about half the pixels' (7C edge-lit at 1 m: median 2.4 %, 90th
#: percentile 4.3 % of the 72 patch cells; 6 seeds): in the agreement table's worst cells there (7C edge-lit 0.5 and
#: 1 m, dark patches in blue) most of the difference's noise was this.  A target of 3 % would trace 2-4 times the
#: photons in 13 of the demo's 48 turbid edge-lit cases (about +60 s of the demo on the slow 2-core machine, whose
#: budget is 10 min); 5 % does in 4 (about +10 s).
NOISE_TARGET = 0.05
#: Most photons the noise target may ask for, in multiples of the image's default (:func:`default_photons`): the
#: tracer's time grows with them (2-3 s per 100 000 photons in turbid water on 2 cores).
MAX_PHOTON_FACTOR = 4


def photon_factor(noise: float, target: float = NOISE_TARGET, cap: int = MAX_PHOTON_FACTOR) -> int:
    """How many times the photons already traced bring a noise of ``noise`` to ``target`` (the noise falls as
    1/√photons), at least 1 and at most ``cap``; 1 where the noise is unknown (NaN: no light of class B)."""
    if not np.isfinite(noise) or noise <= target or target <= 0:
        return 1
    return int(min(max(1, cap), np.ceil((noise / target) ** 2)))


#: Low-resolution grid along the longer image side (the class-B light is smooth across the image;
#: 48 cells gave nine times the cells' noise for no detail the 96×64 comparisons could see).
DEFAULT_GRID = 16
#: Cells of the class-B grid beyond each side of the image (two standard deviations of the widest
#: kernel in the water, :data:`KERNEL_MAX_CELLS`): the photons' light there is recorded too, so that the
#: kernel averages the image's outer cells with the light really beyond them and not with copies of
#: themselves (``mode="nearest"``), then cut off.  The veil rises steeply towards the image's sides where
#: the strobes' beams are, and the copies took it down there: measured 2026-12-04 (Jerlov 9C, 450 nm,
#: twin-strobes-45-wide, open water, 96 x 64, class-B veil of the outer 12-pixel columns left / right, 24
#: seeds of 100 000 photons; against the exact estimators — collision estimator, no δ-truncation, no
#: kernel — on 48 cells, 12 seeds of 200 000: 4.43 / 4.43 ± 0.06 / 0.10, in 1e-4 W m⁻² sr⁻¹ nm⁻¹ per unit
#: power) unpadded 4.10 / 4.03 (± 0.07 / 0.09), without the kernel 4.31 / 4.24 (± 0.09), padded: see
#: ``tests/preview/test_multiple.py::test_the_kernel_sees_the_light_beyond_the_image_edges``.
GRID_PAD = 3
#: Logarithmic range bins of the veil (more edges at the targets: :func:`range_edges`).
N_RANGE_BINS = 24
#: Texture cells per surface side.
TEXTURE = 8
#: Wavelengths the photons carry (evenly spaced over the image's bands; the result is interpolated
#: linearly to every band, per light and per unit of its emitted power, then times the light's own
#: spectrum).  The multiply scattered light is the water's transport, smooth in wavelength (the
#: absorption and scattering spectra are; the lamp's spectrum, which need not be, is applied at the
#: full band resolution afterwards): 8 nodes over 400–700 nm are 43 nm apart.
SPECTRAL_NODES = 8
#: Points per free flight of the veil's track-length estimator (:func:`_splat_track`).
TRACK_POINTS = 1
#: The δ-truncated turns put back as turns along the flights (:class:`ConeTurns`).
CONE_TURNS = True
#: Chains of turns in :attr:`ConeTurns.composed` (each composition of N turns is a sample of this many).
COMPOSED_SAMPLES = 8192
#: Longest chain of turns in :attr:`ConeTurns.composed`.
COMPOSED_TURNS = 64
_MAX_BOUNCES = 400
#: Distance from the entrance pupil (m) within which the Russian roulette looks at a photon's weight
#: alone; beyond it (and beyond twice the farthest target) the weight is discounted by the camera
#: leg's transmittance ``e^{−κ (D − D0)}`` (:func:`roulette_importance`).  Roulette is unbiased for any
#: survival probability; this only chooses which photons are worth their cost.  Without it most of
#: the tracer's work was spent far out: in the demo's coastal water (blue albedo 0.94, δ-truncated
#: mean free path ~25 m) 57 % of the scattering vertices lay more than 40 m from the camera and 26 %
#: beyond 80 m, where what they scatter towards the camera is attenuated by e^{−κ D}.  Measured
#: (2026-12-04, demo scenes at 96 × 64, 8 seeds, class-B veil over the open water and the target and
#: class-B irradiance on the target, blue / green / red; the means agreed within one standard error
#: and their standard errors stayed 0.4–1.8 % as without): tracer time coastal + marine snow, chart at
#: 3 m 5.65 → 2.75 s; clear, black disk at 6 m 3.28 → 1.97 s; Jerlov 3C, edge lighting, chart at 1 m
#: 3.31 → 2.71 s.  (Starting the discount at 1 m instead halved the time again in coastal water but
#: tripled the target irradiance's noise: light from behind a target scatters back onto it.)
ROULETTE_FREE_M = 10.0
#: A photon whose :func:`roulette_importance` is below this fraction of its starting weight survives
#: the roulette with probability ∝ it.  Measured (2026-12-04, the three scenes above, 8 seeds; 0.05 →
#: 0.2): tracer 2.65 → 1.89 s (coastal + snow), 2.06 → 1.46 s (clear), 2.62 → 1.82 s (Jerlov 3C); the
#: means agreed within a standard error; the standard errors of the open water's class-B veil stayed
#: 0.8–1.8 % (→ 0.9–1.7 %), in front of the target 1.1–2.9 % (→ 1.4–3.1 %), of the target's class-B
#: irradiance 0.4–1.7 % (→ 0.8–1.4 %).  At 0.1 the time fell 13–20 % with no change of the noise.
ROULETTE_WEIGHT = 0.2
#: Radius about the entrance pupil (m) of the near zone, whose veil is gathered by flights aimed at it
#: from every scattering vertex and surface hit (:func:`_splat_near`) rather than by the photons'
#: own flights: the collision and the track-length estimators score the water next to the port
#: only when a photon happens to scatter there or pass it, which in an edge-lit Jerlov 3C scene
#: left a quarter of the class-B veil (0.36–0.48 m) to 72 vertices (a coefficient of variation of
#: 1.2 between batches of photons).
NEAR_ZONE_M = 1.0
#: World-space smoothing length of the class-B veil (m): each range bin's veil is blurred across the
#: image with a Gaussian of this size at the bin's distance (angle ``KERNEL_M / s``), a kernel
#: density estimate in the water (as volume photon mapping, Jensen & Christensen 1998) rather than
#: in the image: near the port a cell's frustum is a few centimetres wide and few photons land in
#: it (in an edge-lit Jerlov 3C scene 35 % of the class-B veil at the image centre came from
#: 0.2–0.5 m, with a coefficient of variation of 1 between seeds), while the light scattered there
#: by more than 30° twice is smooth over decimetres.  Far away the blur is below a cell.
KERNEL_M = 0.2
#: The class-B kernel's width in the image is at most this many cells of the class-B grid (its
#: standard deviation).  Near the port ``KERNEL_M / s`` is tens of cells (17 in the first range bin of a
#: 16 mm lens behind a dome): there the kernel spread a bin's light over many times the image, the
#: middle of a veil brightest in the middle fell to half and a third of its light was lost
#: (``test_the_kernel_in_the_water_keeps_the_shape_and_the_light_of_a_near_port_veil``), the light
#: of the water in front of a target moved onto the open water around it, and one vertex's outlier
#: spread over the whole image.  Capped at 1.5 cells (2026-12-03, 12 fast seeds against 16 Monte Carlo
#: renders of 32 spp at 96 x 64, twin strobes, ColorChecker; blue / green / red open water around it;
#: uncapped -> capped): Jerlov 7C at 3 m -6.1 / -4.2 / -3.1 -> -4.9 / -3.4 / -2.4 % (+- 0.2-0.6), its
#: black patch +4.8 / +7.0 / +4.2 -> +0.9 / +4.9 / +2.4 %, white +5.0 / +5.7 / +5.9 -> -0.3 / +2.7 / +3.5 %;
#: 9C at 1 m -8.3 / -5.3 / -3.2 -> -6.0 / -4.0 / -2.4 %; III at 3 m -1.2 / -1.4 / -1.1 -> -0.6 / -1.0 /
#: -0.7 %; 5C at 1 m -3.4 / -1.9 / -0.3 -> -3.1 / -2.0 / -0.7 %.  The spread of the open water's blue
#: mean between seeds: 9C 2.7 -> 1.5 %, 7C 2.1 -> 1.1 %, 5C 0.9 -> 0.6 %.
KERNEL_MAX_CELLS = 1.5
#: Smoothing length (m) of the class-B irradiance on a flat target of several pieces in one plane (a
#: ColorChecker's 24 patches, a slanted edge's two halves): a local-quadratic kernel regression over the
#: texture cells of all its pieces (:func:`_smooth_on_targets`), a density estimate over the target as the
#: kernel in the water is one over the water.  Each patch's own 64 cells hold a twenty-fifth of the chart's
#: photons, while the light that reaches it after a wide-angle scattering (or off the water after leaving
#: the chart) changes over decimetres.  Measured 2026-12-05 (``twin-strobes-45-wide``, the chart 40 % of the
#: field, 12 seeds of 100 000 photons; each patch's class-B irradiance, smoothed against raw, paired): Jerlov
#: 3C at 1 m — its spread between seeds 11.5 % raw; local-linear 0.05 / 0.1 / 0.15 m: 0.78 / 0.59 / 0.52 of it,
#: but the chart's mean −0.3 / −0.8 / −1.0 % (± 0.1–0.2; the fit's curvature bias at the chart's edges, where
#: the light falls off); local-quadratic 0.1 / 0.15 / 0.2 m: 0.75 / 0.65 / 0.59, the chart's mean +0.06 / −0.01 /
#: −0.06 % (± 0.15); Jerlov 9C at 1 m and III at 3 m (the chart 2.7 m wide), local-quadratic 0.2 m: 0.54 and
#: 0.78 of the raw spread, the mean −0.16 ± 0.11 and +0.03 ± 0.05 %, each patch within its noise of its raw
#: mean (z rms 0.8–1.2).  None: each piece's own cells.
TARGET_KERNEL_M: float | None = 0.2
#: Degree of the local polynomial of :data:`TARGET_KERNEL_M` (2: a quadratic field is kept exactly).
TARGET_KERNEL_DEGREE = 2
#: The near zone's flights are drawn from two strategies, combined by the balance heuristic (Veach &
#: Guibas 1995): uniform in the cone that holds the zone, and — with probability
#: :data:`NEAR_AIM_FRACTION` — aimed at a point of a disc of radius :data:`NEAR_AIM_RADIUS_M` about the
#: pupil, facing the vertex, at a distance ρ from the pupil uniform in [0, R] (a direction density
#: ∝ 1/ρ).  A flight passing at h from the pupil gathers ∝ 1/h of veil (its equiangular integral):
#: drawn uniformly, the few flights that pass close carried large weights — in an edge-lit Jerlov 3C
#: scene at 1.5 m one flight in 40 000 held a tenth of the near zone's veil, and the chart's backscatter
#: share was 0.226 ± 0.010 (s.d. over 8 seeds of 100 000 photons, up to 0.248); the second strategy
#: draws them as often as they matter.
NEAR_AIM_FRACTION = 0.5
NEAR_AIM_RADIUS_M = 0.3


@dataclass(frozen=True, eq=False)
class MultipleScattering:
    """Class-B light (see module docstring) of one light group.

    Attributes
    ----------
    veil_cum
        (rows, cols, n_range + 1, B) cumulative veil radiance up to each range-bin edge,
        W/(m² sr nm) (or J/(m² sr nm) per flash for strobes), of the paths that met no surface:
        water-scattered light, what the renderer's ``backscatter`` layer (targets black) holds.
    veil_surf_cum
        The same of the paths that met a surface before their last scattering (light reflected by
        a target, then scattered into the camera): in the image, not in the ``backscatter`` layer.
    range_edges_m
        (n_range + 1,) range from the entrance pupil of the bin edges (m).
    cell_col, cell_row
        Pixel coordinates (full resolution) of the low-resolution cell centres.
    irradiance
        (S, TEXTURE, TEXTURE, B) class-B irradiance on each surface's texture cells, W/(m² nm).
    fluence
        (rows, cols, n_range, B) class-B light in the water of each low-resolution cell and range bin as a
        diffuse sphere there sends it to the camera, ``∫ L(ω) p_L(ω · towards the camera) dω`` (W/(m² sr
        nm); ``p_L`` :func:`rigsim.water.particles.lambert_sphere_phase`): a particle's intensity is this ×
        its cross-section × reflectance (:mod:`rigsim.preview.particles`); by the track-length estimator
        of the flights, smoothed as the veil.
    relative_noise
        Standard error of the veil over the image / its mean, and of the surfaces' irradiance /
        its mean (from independent batches of photons).
    photons, vertices, seconds
        Work done.
    batches
        The same four arrays (``veil_cum``, ``veil_surf_cum``, ``irradiance``, ``fluence``) of each
        independent batch of photons, with a leading batch axis (float32; their mean over the batches is
        the arrays above), or None: what :meth:`batch` returns, for the noise the photons put into a
        number measured on the image (:func:`rigsim.preview.model.render_photon_batches`).
    """

    veil_cum: np.ndarray
    veil_surf_cum: np.ndarray
    range_edges_m: np.ndarray
    cell_col: np.ndarray
    cell_row: np.ndarray
    irradiance: np.ndarray
    fluence: np.ndarray
    relative_noise: tuple[float, float]
    photons: int
    vertices: int
    seconds: float
    batches: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None = None

    @property
    def n_batches(self) -> int:
        """Independent batches of photons kept (0: none kept)."""
        return 0 if self.batches is None else int(self.batches[0].shape[0])

    def batch(self, k: int) -> "MultipleScattering":
        """The class-B light of batch ``k`` of the photons alone (an estimate as unbiased as the mean,
        with ``n_batches`` times its variance); an image made with each batch in turn scatters about the
        image made with the mean as the photons' noise makes any number measured on it."""
        if not 0 <= k < self.n_batches:
            raise IndexError(f"batch {k} of {self.n_batches}")
        v, vs, irr, flu = (np.asarray(a[k], np.float64) for a in self.batches)
        return dataclasses.replace(self, veil_cum=v, veil_surf_cum=vs, irradiance=irr, fluence=flu,
                                   relative_noise=(float("nan"), float("nan")),
                                   photons=self.photons // self.n_batches, batches=None)

    def merged(self, other: "MultipleScattering") -> "MultipleScattering":
        """This light and ``other`` (the same scene, image size and settings, photons of an independent
        stream: :func:`trace_multiple`'s ``stream``) as one estimate: each array the mean of the two weighted
        by their photons, batch ``k`` of one with batch ``k`` of the other (so ``n_batches`` and what
        :func:`rigsim.preview.model.render_photon_batches` measures stay as for one trace)."""
        if not np.allclose(self.range_edges_m, other.range_edges_m) or self.veil_cum.shape != other.veil_cum.shape \
                or self.irradiance.shape != other.irradiance.shape or self.n_batches != other.n_batches:
            raise ValueError("merged: the two traces are not of the same scene, size and settings")
        n1, n2 = float(self.photons), float(other.photons)
        w1, w2 = n1 / (n1 + n2), n2 / (n1 + n2)
        mix = [w1 * np.asarray(a, np.float64) + w2 * np.asarray(b, np.float64)
               for a, b in ((self.veil_cum, other.veil_cum), (self.veil_surf_cum, other.veil_surf_cum),
                            (self.irradiance, other.irradiance), (self.fluence, other.fluence))]
        batches = None
        if self.batches is not None:
            batches = tuple((w1 * a.astype(np.float64) + w2 * b.astype(np.float64)).astype(np.float32)
                            for a, b in zip(self.batches, other.batches))

        def totals(a):  # each batch's sum over the image (and bands)
            return a.reshape(a.shape[0], -1).astype(np.float64).sum(axis=1)

        noise = ((_batch_noise(totals((batches[0] + batches[1])[:, :, :, -1])), _batch_noise(totals(batches[2])))
                 if batches is not None else (float("nan"), float("nan")))
        return dataclasses.replace(self, veil_cum=mix[0], veil_surf_cum=mix[1], irradiance=mix[2], fluence=mix[3],
                                   relative_noise=noise, photons=self.photons + other.photons,
                                   vertices=self.vertices + other.vertices, seconds=self.seconds + other.seconds,
                                   batches=batches)

    def scaled(self, sx: float, sy: float) -> "MultipleScattering":
        """The same light for an image of the same view ``sx`` times as wide and ``sy`` times as tall in
        pixels (the cells' pixel coordinates scaled; radiances and irradiances do not depend on the
        pixel size)."""
        return dataclasses.replace(self, cell_col=self.cell_col * float(sx), cell_row=self.cell_row * float(sy))

    def veil_at(self, col: np.ndarray, row: np.ndarray, range_m: np.ndarray, *, surfaces: bool = False) -> np.ndarray:
        """Veil radiance (…, B) at full-resolution pixels ``(col, row)`` up to their range (inf: all):
        of the paths that met no surface (``surfaces=False``) or of those that did (``True``)."""
        cum = self.veil_surf_cum if surfaces else self.veil_cum
        R, C, M, B = cum.shape

        def idx(x, nodes):
            k = np.clip(np.searchsorted(nodes, x, side="right") - 1, 0, len(nodes) - 2)
            f = np.clip((x - nodes[k]) / (nodes[k + 1] - nodes[k]), 0.0, 1.0)
            return k, f

        ic, fc = idx(col, self.cell_col) if C > 1 else (np.zeros(np.shape(col), int), np.zeros(np.shape(col)))
        ir, fr = idx(row, self.cell_row) if R > 1 else (np.zeros(np.shape(row), int), np.zeros(np.shape(row)))
        lr = np.log(self.range_edges_m)
        x = np.log(np.clip(np.where(np.isfinite(range_m), range_m, self.range_edges_m[-1]),
                           self.range_edges_m[0], self.range_edges_m[-1]))
        js, fs = idx(x, lr)
        flat = cum.reshape(R * C * M, B)
        out = 0.0
        ic1 = np.minimum(ic + 1, C - 1)
        ir1 = np.minimum(ir + 1, R - 1)
        for rr, wr in ((ir, 1 - fr), (ir1, fr)):
            for cc, wc in ((ic, 1 - fc), (ic1, fc)):
                base = (rr * C + cc) * M + js
                a = np.take(flat, base, axis=0)
                b = np.take(flat, base + 1, axis=0)
                out = out + (wr * wc)[..., None] * (a + (b - a) * fs[..., None])
        return out

    def fluence_at(self, col: np.ndarray, row: np.ndarray, range_m: np.ndarray) -> np.ndarray:
        """:attr:`fluence` (…, B) at full-resolution image positions ``(col, row)`` and distance ``range_m``
        from the pupil (the cell and range bin they fall in)."""
        R, C, M, _ = self.fluence.shape
        ic = np.clip(np.floor(np.asarray(col, float) / (self.cell_col[0] * 2)).astype(np.int64), 0, C - 1)
        ir = np.clip(np.floor(np.asarray(row, float) / (self.cell_row[0] * 2)).astype(np.int64), 0, R - 1)
        kb = np.clip(np.searchsorted(self.range_edges_m, np.asarray(range_m, float), side="right") - 1, 0, M - 1)
        return self.fluence[ir, ic, kb]

    def irradiance_at(self, surf: SceneSurfaces, oid: np.ndarray, points: np.ndarray,
                      normals: np.ndarray) -> np.ndarray:
        """Class-B irradiance (N, B) at surface points ``points`` (N, 3) of objects ``oid`` (1-based), on
        the side whose normal is ``normals`` (N, 3)."""
        k = np.asarray(oid) - 1
        iu, iv = _texture_cell(surf, k, points, normals)
        return self.irradiance[k, iu, iv]


@dataclass(frozen=True, eq=False)
class _Cells:
    """The class-B grid: ``cols × rows`` cells over the image and :data:`GRID_PAD` more beyond each of its
    sides (``pad``), whose light the kernel in the water (:func:`_smooth_in_water`) averages into the
    image's outer cells and which is cut off afterwards.  ``omega`` (rows + 2 pad, cols + 2 pad): the
    cells' solid angles (sr)."""

    cam: object
    width: int
    height: int
    cols: int
    rows: int
    pad: int
    n_out: float
    omega: np.ndarray

    def of(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(inside, ir, ic)``: which of the world points ``x`` (n, 3) the grid holds, and their cells'
        (padded) row and column indices (of those inside)."""
        px = project_points(self.cam, x, self.width, self.height, n_outside=self.n_out)
        ic = np.floor(px[:, 0] / self.width * self.cols) + self.pad
        ir = np.floor(px[:, 1] / self.height * self.rows) + self.pad
        inside = (np.isfinite(ic) & np.isfinite(ir) & (ic >= 0) & (ic < self.cols + 2 * self.pad) & (ir >= 0)
                  & (ir < self.rows + 2 * self.pad))
        return inside, ir[inside].astype(np.int64), ic[inside].astype(np.int64)

    @property
    def cell_rad(self) -> float:
        """Angular size (rad) of a cell of the image: the square root of the median solid angle of its own cells."""
        p = self.pad
        own = self.omega[p:p + self.rows, p:p + self.cols]
        return float(np.sqrt(np.median(own)))

    def crop(self, a: np.ndarray) -> np.ndarray:
        """The image's own cells of ``a`` (…, rows + 2 pad, cols + 2 pad, bins, bands)."""
        p = self.pad
        return a[..., p:p + self.rows, p:p + self.cols, :, :] if p else a


def _texture_half_sizes(surf: SceneSurfaces, k: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Half-width and half-height (m) of the square the texture of surfaces ``k`` (0-based) covers: a flat
    piece's own; a disk's and a mesh's square of their radius each way."""
    hw = surf.half_size[k, 0]
    return hw, np.where(surf.is_disk[k] | surf.is_mesh[k], hw, surf.half_size[k, 1])


def _texture_cell(surf: SceneSurfaces, k: np.ndarray, p: np.ndarray, side_normal: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Texture cell of points ``p`` on surfaces ``k`` (0-based): a flat piece's own square of TEXTURE²
    cells; a mesh's square about its centre in its (u, v) plane, TEXTURE × TEXTURE/2 cells for the side
    facing the mesh's ``normal`` (the camera) and as many for the side facing away (``side_normal``: the
    normal of the side the light meets or the camera sees)."""
    rel = p - surf.center[k]
    a = np.sum(rel * surf.u[k], axis=-1)
    b = np.sum(rel * surf.v[k], axis=-1)
    hw, hh = _texture_half_sizes(surf, k)
    iu = np.clip(((a / np.maximum(hw, 1e-12) + 1) * 0.5 * TEXTURE).astype(np.int64), 0, TEXTURE - 1)
    fv = (b / np.maximum(hh, 1e-12) + 1) * 0.5
    iv = np.clip((fv * TEXTURE).astype(np.int64), 0, TEXTURE - 1)
    mesh = surf.is_mesh[k]
    if np.any(mesh):
        half = TEXTURE // 2
        back = np.sum(side_normal * surf.normal[k], axis=-1) < 0
        iv_m = np.clip((fv * half).astype(np.int64), 0, half - 1) + np.where(back, half, 0)
        iv = np.where(mesh, iv_m, iv)
    return iu, iv


#: (TEXTURE, TEXTURE) fraction of each cell of a disk's bounding square on the disk.  Until 2026-12-03 the cells
#: whose centres are on the disk shared its area equally: a whole cell inside held π/52 of r² for its 1/16,
#: and the class-B irradiance of the disk's interior read 3–4 % high, its rim low
#: (``test_a_disks_texture_cells_hold_the_irradiance_of_their_part_of_the_disk``: +4.0 ± 0.4 %).
_DISK_CELL_FRACTION = disk_cell_fraction(TEXTURE)


def _cell_areas(surf: SceneSurfaces) -> np.ndarray:
    """(S, TEXTURE, TEXTURE) area of each texture cell (m²): a flat piece's cells are equal squares; a
    disk's cells are the squares of its bounding square, each holding the part of it on the disk
    (:data:`_DISK_CELL_FRACTION`; a cell off the disk gets no light); a mesh's cells hold the area of its
    triangles (16 points on each) on the side facing the cell's way (the file's winding taken as outward)."""
    hw, hh = _texture_half_sizes(surf, np.arange(len(surf)))
    square = 4 * hw * hh / (TEXTURE * TEXTURE)
    frac = np.where(surf.is_disk[:, None, None], _DISK_CELL_FRACTION[None], 1.0)
    out = np.where(frac > 0, square[:, None, None] * frac, np.inf)
    ms = surf.meshes
    if ms is not None:
        g = (np.arange(4) + 0.5) / 4
        su, sv = np.meshgrid(g, g, indexing="ij")
        su, sv = su.ravel(), sv.ravel()
        fold = su + sv > 1  # fold the unit square onto the triangle (uniform in area)
        su, sv = np.where(fold, 1 - su, su), np.where(fold, 1 - sv, sv)
        pts = ms.v0[:, None] + su[None, :, None] * ms.e1[:, None] + sv[None, :, None] * ms.e2[:, None]
        k = np.repeat(ms.oid - 1, len(su))
        nrm = np.repeat(ms.geo_normal, len(su), axis=0)
        iu, iv = _texture_cell(surf, k, pts.reshape(-1, 3), nrm)
        for m in np.unique(ms.oid - 1):
            out[m] = 0.0
        np.add.at(out, (k, iu, iv), np.repeat(ms.area_m2 / len(su), len(su)))
        for m in np.unique(ms.oid - 1):
            a = out[m]
            a[a <= 0] = np.inf  # cells with no surface get no light
    return out


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise dot products of (n, 3) arrays (``np.einsum``: 3x faster than ``np.sum(a * b, axis=1)``)."""
    return np.einsum("ij,ij->i", a, b)


def _norm(v: np.ndarray) -> np.ndarray:
    """Row-wise lengths of an (n, 3) array (3x faster than ``np.linalg.norm(v, axis=1)``)."""
    return np.sqrt(np.einsum("ij,ij->i", v, v))


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise cross products of (n, 3) arrays (2.4x faster than ``np.cross``)."""
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    out[:, 0] = a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1]
    out[:, 1] = a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2]
    out[:, 2] = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    return out


def roulette_importance(F: np.ndarray, distance_m: np.ndarray, kappa_per_m: np.ndarray, free_m: float) -> np.ndarray:
    """What the Russian roulette weighs a photon by: its largest band weight of ``F`` (n, B) times the
    camera leg's transmittance ``e^{−κ (D − free_m)}`` from its distance ``distance_m`` (n,) to the pupil
    beyond ``free_m`` (:data:`ROULETTE_FREE_M`; ``kappa_per_m`` (B,) the camera leg's attenuation,
    ``c − bF``): what it scatters towards the camera from there is attenuated by at least that much more
    than from ``free_m``."""
    beyond = np.maximum(np.asarray(distance_m, float) - float(free_m), 0.0)
    return (F * np.exp(-np.outer(beyond, kappa_per_m))).max(axis=1)


def range_edges(reach_m: float, r_max_m: float, surf: SceneSurfaces, pupil: np.ndarray) -> np.ndarray:
    """Edges (m from the pupil) of the veil's range bins: :data:`N_RANGE_BINS` logarithmic ones from ``reach_m``
    to ``r_max_m``, and the nearest and farthest distance of every target's extent (overlapping extents merged).

    Why: :meth:`MultipleScattering.veil_at` reads each pixel's veil up to its own range by interpolating the
    cumulative veil linearly in log range inside the bin that holds it, as if the bin's light were spread
    evenly over it.  In front of a target it is not: the light of the bin that holds the target lies before
    it (behind it the target hides the water), and the light the target itself sends out and the water
    scatters back (the ``veil_surf_cum`` part) crowds next to it.  With the bins' edges at the target the
    bin before it is read whole and the bin across it spans only the target's own depth.  Measured
    (2026-12-05, ``single-strobe-short-arm``, a ColorChecker 40 % of the field at 1 m in Jerlov 7C, 550 nm,
    bins of 0.90-1.18 m without the edges): the chart's light scattered back after leaving it read 5.5 % of
    the chart's reflected light, 6.6 % with its bin read whole; with the edges 6.3 % (6.5 % whole).  The rest
    of the 7.1-7.3 % of the exact estimators (collision estimator, no δ-truncation, no kernel in the water,
    2 000 000 photons) is the kernel in the water's (:data:`KERNEL_M`): it spreads this light, which has the
    chart's outline, onto the water around it (without the kernel the patches' noise doubled).
    """
    edges = np.geomspace(reach_m, r_max_m, N_RANGE_BINS + 1)
    if not len(surf):
        return edges
    rel = pupil[None, :] - surf.center
    hu = surf.half_size[:, 0]
    hv = np.where(surf.is_disk, surf.half_size[:, 0], surf.half_size[:, 1])
    du = np.clip(_dot(rel, surf.u), -hu, hu)
    dv = np.clip(_dot(rel, surf.v), -hv, hv)
    near = _norm(rel - du[:, None] * surf.u - dv[:, None] * surf.v)
    far = np.max([_norm(rel - su * hu[:, None] * surf.u - sv * hv[:, None] * surf.v)
                  for su in (-1, 1) for sv in (-1, 1)], axis=0)
    mesh = surf.is_mesh
    if np.any(mesh):  # a mesh: the sphere about its bounding square
        rad = np.sqrt(2.0) * surf.half_size[:, 0]
        d0 = _norm(rel)
        near = np.where(mesh, np.maximum(d0 - rad, 0.0), near)
        far = np.where(mesh, d0 + rad, far)
    order = np.argsort(near)
    extra = []
    lo, hi = near[order[0]], far[order[0]]
    for k in order[1:]:
        if near[k] <= hi:
            hi = max(hi, far[k])
        else:
            extra += [lo, hi]
            lo, hi = near[k], far[k]
    extra += [lo, hi]
    extra = np.asarray(extra)
    extra = extra[(extra > reach_m * 1.01) & (extra < r_max_m / 1.01)]
    if extra.size:  # no sliver of a bin beside a target's edge: a logarithmic edge within 1 % of one goes
        gap = np.min(np.abs(np.log(edges[:, None] / extra[None, :])), axis=1)
        keep = gap > 0.01
        keep[[0, -1]] = True
        edges = edges[keep]
    return np.unique(np.concatenate([edges, extra]))


def _farthest_surface_m(surf: SceneSurfaces, pupil: np.ndarray) -> float:
    """Distance (m) from ``pupil`` to the farthest point of any target's bounding square (0 without targets)."""
    if not len(surf):
        return 0.0
    r = _norm(surf.center - pupil) + np.sqrt(2.0) * surf.half_size.max(axis=1)
    return float(r.max())


def _rotate(d: np.ndarray, cos_t: np.ndarray, phi: np.ndarray) -> np.ndarray:
    """Turn unit directions ``d`` by angle acos(cos_t) at azimuth ``phi`` about themselves."""
    sin_t = np.sqrt(np.clip(1.0 - cos_t * cos_t, 0.0, 1.0))
    helper = np.where(np.abs(d[:, 0:1]) < 0.9, np.array([[1.0, 0.0, 0.0]]), np.array([[0.0, 1.0, 0.0]]))
    e1 = _cross(d, helper)
    e1 /= _norm(e1)[:, None]
    e2 = _cross(d, e1)
    return (cos_t[:, None] * d + (sin_t * np.cos(phi))[:, None] * e1 + (sin_t * np.sin(phi))[:, None] * e2)


class ConeTurns:
    """The scatterings by less than the truncation angle ψ_t put back into the δ-truncated flights as turns
    along them, without making them vertices (no splat, no ray cast, no roulette at them).

    Along a path of length ℓ the cone's scatterings are a Poisson process of rate ``r_λ = b_λ F_λ`` (1/m),
    each turning the photon by an angle drawn from the cone's part of the phase function (the forward cells
    of :meth:`PhaseTables.forward_only`, azimuth uniform); they neither absorb nor count as events.  What
    the tracer needs of them is the direction at a point of a flight: where the flight scatters next (its end;
    the next turn starts from there), and at the points where the veil's estimators score the light
    scattered towards the camera (:func:`_splat_track`, :func:`_splat_near`), whose phase function is steep
    just beyond ψ_c.  Each is drawn on its own (:meth:`deflect`: unbiased for each estimate, only the
    correlation between a flight's points is lost).  The points themselves stay on the flight's straight
    line: the bent path's sideways spread of position (a third of its spread of direction in variance) is
    left out, as the targets' ray casts see the straight line.  Unbiased for the transport otherwise.

    Measured (twin-strobes-edge-lighting, black disk at 0.5 m, Jerlov 9C, 48 x 32, 48 Monte Carlo renders
    of 64 paths split by class, 6 seeds of 400 000 photons; the class-B veil of the open water as a fraction
    of Monte Carlo's, blue / green / red, ± 1-3 %): δ-truncation at 30 deg alone 0.916 / 0.893 / 0.928; at
    15 deg (the 15-30 deg turns as vertices, 1.5 x the tracer's time) 0.963 / 0.927 / 0.957; these turns at
    30 deg 0.977 / 0.934 / 0.960 for 1.35 x the time (whole veil 0.986 / 0.967 / 0.988 against 0.954 / 0.947
    / 0.975).  A Gaussian angular diffusion with the cone's ⟨1 − cos θ⟩ instead (its Fokker-Planck limit)
    changed nothing (0.913 / 0.885 / 0.918): the cone's turns are few per flight and heavy-tailed (9C at
    450 nm: 3.9 per metre; after 0.68 m, the mean flight, 5.9 % of the photons are turned by more than 30
    deg, median 9 deg; the Gaussian: 1.1 %, median 12.7 deg), and the tail is what matters.
    """

    def __init__(self, tables: PhaseTables, weights: np.ndarray, b: np.ndarray, cutoff_rad: float):
        self.cone, Fk = tables.forward_only(cutoff_rad)
        w = weights * Fk[None, :]  # (B, K) each component's cone mass at each node
        F = w.sum(axis=1)
        self.rate = b * F  # (B,) 1/m
        self.weights = w / np.maximum(F, 1e-300)[:, None]
        # (cells, B): each node's probability of a turn into each cell (0 outside the cone)
        self.cell_prob = self.cone.masses.T @ self.weights.T

    def deflect(self, d: np.ndarray, length_m: np.ndarray, hero: np.ndarray, rng
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The direction after a path of ``length_m`` (n,) from directions ``d`` (n, 3) with the turns on the
        way, without the path's points (for the near zone's flights, which need the direction at one point
        each): the number of turns drawn with the hero's rate (Poisson), their composition from
        :attr:`composed` (drawn from the bands' mean cone).  Returns the directions, (n, B) each band's
        density of the number of turns over the hero's, and (n, B) each band's density of the turns' angles
        over the mean cone's."""
        ell = np.where(np.isfinite(length_m), length_m, 0.0)
        k = rng.poisson(self.rate[hero] * ell)
        cos_t, w = self.composed
        row = np.minimum(k, len(cos_t) - 1)
        col = rng.integers(0, cos_t.shape[1], len(d))
        out = _rotate(d, cos_t[row, col], 2 * np.pi * rng.random(len(d)))
        r = np.maximum(self.rate, 1e-300)
        rate = np.exp(k[:, None] * np.log(r[None, :] / r[hero][:, None]) - np.outer(ell, r) + (ell * r[hero])[:, None])
        return out, rate, w[row, col]

    @property
    def composed(self) -> tuple[np.ndarray, np.ndarray]:
        """:func:`_composed_turns` of this cone (cached: the same water and bands give the same table)."""
        return _composed_turns(self.cell_prob, self.cone.v_edges)


#: Tables of :func:`_composed_turns` kept (by their cone's cell probabilities and cell edges).
_COMPOSED: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}


def _composed_turns(cell_prob: np.ndarray, v_edges: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The composition of N turns, N = 0 … :data:`COMPOSED_TURNS`, for a cone of (cells, B) turn probabilities
    ``cell_prob`` on cells of edges ``v_edges`` (in 1 − cos ψ): ``(cos, w)``, (N + 1, S) the cosine of the whole
    turn of :data:`COMPOSED_SAMPLES` chains of turns drawn from the bands' mean cone ``q``, and (N + 1, S, B)
    each band's density of each chain's turns over ``q``'s (``Π pc_λ / q``, float32).  Each step's S turns are
    a stratified sample of ``q`` (a table of plain random turns had put Jerlov 9C's mean turn after 0.7 m
    1.8 % too wide: the cone's turns are heavy-tailed).  A chain of more turns than the table holds takes
    its last row (in Jerlov 9C, 64 turns are 17 m at 450 nm, whose light is e^{−c·17 m} weak)."""
    key = hashlib.sha1(np.ascontiguousarray(cell_prob).tobytes() + np.ascontiguousarray(v_edges).tobytes()).digest()
    if key in _COMPOSED:
        return _COMPOSED[key]
    rng = np.random.default_rng(0x7A9)
    q = cell_prob.mean(axis=1)
    q = q / q.sum()
    cdf = np.cumsum(q)
    cdf[-1] = 1.0
    S, N, B = COMPOSED_SAMPLES, COMPOSED_TURNS, cell_prob.shape[1]
    d = np.tile([0.0, 0.0, 1.0], (S, 1))
    w = np.ones((S, B))
    cos_t = np.ones((N + 1, S))
    ws = np.ones((N + 1, S, B), np.float32)
    for i in range(1, N + 1):
        u = (rng.permutation(S) + rng.random(S)) / S  # stratified
        cell = np.minimum(np.searchsorted(cdf, u, side="right"), len(q) - 1)
        ct = 1.0 - (v_edges[cell] + rng.random(S) * (v_edges[cell + 1] - v_edges[cell]))
        d = _rotate(d, ct, 2 * np.pi * rng.random(S))
        w = w * cell_prob[cell] / np.maximum(q[cell], 1e-300)[:, None]
        cos_t[i] = d[:, 2]
        ws[i] = w
    if len(_COMPOSED) >= 8:
        _COMPOSED.pop(next(iter(_COMPOSED)))
    _COMPOSED[key] = (cos_t, ws)
    return cos_t, ws


def _sample_phase(tables: PhaseTables, W: np.ndarray, hero: np.ndarray, rng) -> np.ndarray:
    """cos ψ for each photon from its hero band's phase function (component, cell, position in v)."""
    cdfs = tables.cdfs
    n = hero.size
    w = W[hero]  # (n, K)
    cw = np.cumsum(w, axis=1)
    cw[:, -1] = 1.0
    u = rng.random(n)
    k = np.minimum((u[:, None] >= cw).sum(axis=1), tables.n_components - 1)
    uc = rng.random(n)
    cell = np.empty(n, np.int64)
    for j in range(tables.n_components):
        m = k == j
        if np.any(m):
            cell[m] = np.minimum(np.searchsorted(cdfs[j], uc[m], side="right") - 1, tables.grid.n_cells - 1)
    v0, v1 = tables.v_edges[cell], tables.v_edges[cell + 1]
    return 1.0 - (v0 + rng.random(n) * (v1 - v0))


def trace_multiple(scene: Scene, surf: SceneSurfaces, lights, wavelength_nm: np.ndarray, *, c: np.ndarray,
                   b: np.ndarray, kappa_cam: np.ndarray, tables: PhaseTables, weights: np.ndarray, width: int, height: int,
                   cutoff_rad: float, photons: int = DEFAULT_PHOTONS, grid: int = DEFAULT_GRID, seed: int = 0,
                   batches: int = 4, classes: str = "B",
                   spectral_nodes: int | None = SPECTRAL_NODES,
                   truncate_rad: float | None = None,
                   track_points: int = TRACK_POINTS, bandwidth_nm=None, surface_nee: bool = True,
                   cone_turns: bool | None = None, stream: int = 0) -> MultipleScattering:
    """Class-B light of one group of lights (see module docstring).

    Parameters
    ----------
    scene, surf
        The scene and its target surfaces (:func:`rigsim.preview.geometry.scene_surfaces`).
    lights
        The :class:`~rigsim.scene.types.Light` objects of the group (all strobes or all continuous).
    wavelength_nm, c, b, weights
        Band centres (B,), beam attenuation and scattering coefficient (1/m, (B,)) and the phase
        components' weights (B, K) there.
    bandwidth_nm
        Band widths (nm; default :func:`rigsim.spectrum.band_edges`): each light's power in a band is
        its spectrum's average over the band (:func:`rigsim.spectrum.band_average`), as the renderer's
        and the analytic model's — a flash spectrum that starts at 400 nm has half its centre value in
        the 395–405 nm band (with the centre value the multiply scattered light there was twice the
        renderer's: Jerlov 5C at 1 m, open water at 400 nm +11 % against −4 % in the next band).
    kappa_cam
        (B,) attenuation of the camera leg, ``c − bF`` (1/m), as the analytic model's.
    tables
        The water's :class:`~rigsim.scene.phase_tables.PhaseTables`.
    width, height
        The full image size (pixels).
    cutoff_rad
        ψ_c of the analytic model's forward scattering.
    photons, grid, seed, batches
        Photons in all, cells along the longer image side, seed, independent batches for the noise.
    stream
        Which independent stream of random numbers of ``seed`` (0: the seed's own; ``k`` ≥ 1: the photons
        traced after it, :meth:`MultipleScattering.merged`, independent of stream 0 and of every other seed's).
    spectral_nodes
        Wavelengths the photons carry (:data:`SPECTRAL_NODES`; None or ≥ the bands: every band).
    truncate_rad
        Scatterings by less than this angle (≤ ψ_c; default ψ_c) are taken as no scattering on the
        photons' way (class B only): the flights see ``c − b F_t`` and ``b (1 − F_t)``, the phase
        function without its forward cone, renormalised (δ-scaling: Wiscombe 1977; Joseph, Wiscombe
        & Weinman 1976).  The splat towards the camera (wide angles) is unchanged, ``b p``.  It cuts
        the collisions per photon several-fold in forward-peaked water (most of ``b`` is within a few
        degrees); the scatterings it removes come back as turns along the flights (``cone_turns``),
        without which the class-B veil of turbid water was 4-9 % low; 0: exact.
    cone_turns
        With the δ-truncation, the truncated scatterings put back as turns along each flight
        (:class:`ConeTurns`; None: :data:`CONE_TURNS`); False: the flights go straight.
    track_points
        Points per free flight of the veil's track-length estimator (class B; 0: the collision
        estimator, a splat at each scattering vertex, as the other ``classes``).
    classes
        ``"B"``: class B (see module docstring); ``"A"``: the analytic model's own paths, estimated the
        same way (a check of the analytic model); ``"all"``: every path, with the exact camera leg
        (``e^{−c s}``, every scattering and surface splatted to the camera) — the whole image by
        light tracing, an independent check of the renderer and of the split (noisy: the forward
        peak of the phase function towards the camera); ``"irradiance"``: every path's irradiance on
        the side of each target the camera sees, exact (no δ-truncation), nothing splatted — the light
        leg of the hybrid reference (``benchmarks/bench_reference_hybrid.py``).
    surface_nee
        ``classes="irradiance"`` and ``"B"``: every scattering vertex (with ``"irradiance"`` each light's
        emission point too; class B: only the flights that make the path class B) also sends a flight to a
        point drawn uniformly over the targets' sides the camera sees, combined with the photons' own hits
        by the balance heuristic (:func:`_SurfaceNEE`); False: the hits alone.  Not with meshes (the hits
        alone, whatever this says).
    """
    if classes not in ("B", "all", "A", "qss", "irradiance"):
        raise ValueError("classes must be 'B', 'A', 'qss', 'all' or 'irradiance'")
    irradiance_only = classes == "irradiance"  # every path's irradiance on the targets, nothing splatted
    every = classes == "all"
    qss = classes == "qss"  # (a check) every path, with the quasi-single-scattering camera leg
    only_a = classes == "A"  # (a check of the analytic model) its own paths, estimated the same way
    t0 = time.perf_counter()
    if int(stream) < 0:
        raise ValueError(f"stream must be >= 0, got {stream}")
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), 0x6D55] + ([int(stream)] if stream else [])))
    wl_bands = np.asarray(wavelength_nm, float)
    B_out = len(wl_bands)
    wavelength_nm, to_bands = _spectral_nodes(wl_bands, spectral_nodes)
    c, b, kappa_cam = (_at_nodes(x, wl_bands, wavelength_nm) for x in (c, b, kappa_cam))
    weights = np.stack([_at_nodes(weights[:, k], wl_bands, wavelength_nm) for k in range(weights.shape[1])], axis=1)
    weights = weights / np.maximum(weights.sum(axis=1, keepdims=True), 1e-300)
    B = len(wavelength_nm)
    turns = None
    if classes == "B" and (truncate_rad is None or truncate_rad > 0):
        # δ-truncation: the same tables without the forward cone (each component renormalised; a cell
        # of zero mass is never drawn), and the flights' coefficients without what the cone held
        psi_t = min(float(cutoff_rad if truncate_rad is None else truncate_rad), float(cutoff_rad))
        if CONE_TURNS if cone_turns is None else cone_turns:  # the cone's scatterings as turns along the flights
            turns = ConeTurns(tables, weights, b, psi_t)
        tables, Fk = tables.without_forward(psi_t)  # (K,) what each component lost
        F_t = weights @ Fk  # (B,)
        c = c - b * F_t
        b = b * (1.0 - F_t)
        weights = weights * (1.0 - Fk)[None, :]
        weights = weights / np.maximum(weights.sum(axis=1, keepdims=True), 1e-300)
    cam = scene.camera
    n_out = outside_index(scene)
    pupil = np.asarray(cam.position_m, float)
    reach = port_reach_m(cam)
    step = max(width, height) / float(grid)
    cols, rows = max(1, int(np.ceil(width / step))), max(1, int(np.ceil(height / step)))
    pad = GRID_PAD if cols * rows > 1 and classes == "B" else 0
    omega = cell_solid_angles(cam, cols, rows, n_outside=n_out, pad_cells=pad)
    cells = _Cells(cam, int(width), int(height), cols, rows, pad, n_out, omega)
    r_max = 30.0 / max(float(np.min(c)), 1e-6)
    near_m = max(NEAR_ZONE_M, 2.0 * reach)
    edges = range_edges(reach, max(r_max, 2 * reach), surf, pupil)
    M = len(edges) - 1
    S = len(surf)
    refl = np.stack([_at_nodes(r, wl_bands, wavelength_nm) for r in surf.reflectance(wl_bands)])  # (S+1, B)
    cell_area = _cell_areas(surf) if S else np.zeros(0)
    dens_b = tables.densities.T @ weights.T  # (cells, B): each node's phase function per cell (1/sr)
    nee = (_SurfaceNEE(surf, pupil) if (irradiance_only or classes == "B") and surface_nee and S and surf.meshes is None
           else None)

    power = []
    _, bw = band_edges(wl_bands, bandwidth_nm)
    for light in lights:
        I = band_average(np.asarray(light.wavelength_nm, float), np.asarray(light.axial_intensity, float),
                         wl_bands - bw / 2, wl_bands + bw / 2)
        power.append(I * beam_solid_angle_sr(light.beam))
    power = np.array(power).reshape(len(lights), B_out)  # (L, bands): W/nm (or J/nm)
    L = max(1, len(lights))
    # per light and per unit of its power at every node; the lights' spectra are applied in _result
    veil = np.zeros((batches, L, rows + 2 * pad, cols + 2 * pad, M, B))
    veil_s = np.zeros_like(veil)
    irr = np.zeros((batches, L, max(S, 1), TEXTURE, TEXTURE, B))
    flu = np.zeros_like(veil)
    n_vert = 0
    acc = _Accumulator(veil, veil_s, flu if classes == "B" else None)
    # volume of each cell × range bin of the frustum (m³), for the fluence
    vol = omega[:, :, None] * (edges[1:] ** 3 - edges[:-1] ** 3)[None, None, :] / 3.0
    track = int(track_points) if classes == "B" else 0
    if len(lights) == 0 or not np.any(power > 0) or photons <= 0:
        return _result(*map(cells.crop, (veil, veil_s)), irr, cells.crop(flu), np.zeros((L, B_out)), to_bands, edges, cols, rows, width, height, 0, 0,
                       t0)
    q = power.mean(axis=1)
    q = q / q.sum()
    free_m = max(ROULETTE_FREE_M, 2.0 * _farthest_surface_m(surf, pupil))
    per_batch = max(1, photons // batches)
    cutoff_cos = float(np.cos(cutoff_rad))
    # every batch in one pass (a batch index per photon): the loop runs once per bounce
    n = per_batch * batches
    bid = np.arange(n) % batches
    li = rng.choice(len(lights), size=n, p=q)
    pos = np.empty((n, 3))
    dirs = np.empty((n, 3))
    F = np.empty((n, B))
    for l, light in enumerate(lights):
        m = li == l
        k = int(m.sum())
        if not k:
            continue
        d_loc, _ = sample_beam_direction(light.beam, rng.random(k), rng.random(k))
        dirs[m] = local_to_world(light.aim, d_loc)
        pos[m] = np.asarray(light.position_m, float)
        F[m] = 1.0 / (q[l] * per_batch)
    P = np.ones((n, B))
    hero = rng.integers(0, B, n)
    n_sig = np.zeros(n, np.int32)  # significant events so far: scatterings by more than ψ_c, surfaces
    if nee is not None:
        # the light's own flight to the targets: drawn over their area (the photons' first flights' hits
        # count nothing, below); then per photon its last event (0 light, 1 water, 2 surface), where it
        # was and the hit technique's density factor P_j p_j(ψ) of its last scattering
        if irradiance_only:  # (class B: the lights' direct light is the analytic model's)
            nee.from_lights(irr, lights, li, bid, pos, F, c, cell_area, rng)
        last = np.zeros(n, np.int8)
        x_prev = pos.copy()
        pph = np.ones((n, B))
    touched = np.zeros(n, bool)  # met a surface
    f_ref = F.max(axis=1).copy()
    # the photons still alive, compacted after every bounce
    for _ in range(_MAX_BOUNCES):
        n = len(F)
        if n == 0:
            break
        p, d = pos, dirs
        if S:
            t_s, oid, n_hit = cast_rays(surf, p, d, normals=True)
        else:
            t_s, oid, n_hit = np.full(n, np.inf), np.zeros(n, np.int32), np.zeros((n, 3))
        t = -np.log1p(-rng.random(n)) / c[hero]
        med = t < t_s
        if track and np.any(n_sig >= 1):
            n_vert += _splat_track(acc, np.flatnonzero(n_sig >= 1), np.where(med, t, t_s), p, d, F, P, c, b,
                                   kappa_cam, track, rng, bid, li, touched, pupil, reach, near_m, edges, cutoff_cos,
                                   dens_b, tables, cells, turns=turns, hero=hero)
        d_end = d  # the direction at the flight's end
        if turns is not None:
            # the cone's turns on the way to a scattering (:class:`ConeTurns`; before a surface they change
            # nothing: its reflection is diffuse)
            mt = np.flatnonzero(med)
            d_end = d.copy()
            d_end[mt], R, shape = turns.deflect(d[mt], t[mt], hero[mt], rng)
            F[mt] *= R * shape
            P[mt] *= R
        # ---- free flight: weights for every band, densities for every possible hero
        tt = np.where(med, t, t_s)[:, None]
        T = np.exp(-c[None, :] * np.where(np.isfinite(tt), tt, 0.0))
        F = F * np.where(med[:, None], b[None, :] * T, T)
        P = P * np.where(med[:, None], c[None, :] * T, T)
        norm = P.mean(axis=1, keepdims=True)
        F /= norm
        P /= norm
        new_pos, new_dirs = pos.copy(), dirs.copy()
        # ---- scattering vertices: the light scattered towards the camera
        mv = np.flatnonzero(med)
        if mv.size:
            x = p[mv] + t[mv, None] * d[mv]
            v = pupil - x
            s = _norm(v)
            wv = v / s[:, None]
            cos_psi = _dot(d_end[mv], wv)
            # counted here: a scattering by more than ψ_c towards the camera after another significant
            # event (one alone is the analytic model's quasi-single scattering); the camera leg as the
            # analytic model's, e^{−(c − bF)s}: small-angle scattering on the way back conserved
            ok = (s > reach) & (s < edges[-1]) & (not track) & (not irradiance_only)
            if only_a:
                ok &= (n_sig[mv] == 0) & (cos_psi < cutoff_cos)
            elif qss:
                ok &= cos_psi < cutoff_cos
            elif not every:
                ok &= (n_sig[mv] >= 1) & (cos_psi < cutoff_cos)
            if S and classes != "B" and np.any(ok):
                # (class B needs no test: veil_at stops each pixel's veil at its own range, and a
                # cell's density counts the light its unoccluded pixels see)
                o2 = np.flatnonzero(ok)
                blocked = occluded(surf, x[o2], pupil)
                ok[o2[blocked]] = False
            if np.any(ok):
                o2 = np.flatnonzero(ok)
                inside, ir, ic = cells.of(x[o2])
                o2 = o2[inside]
                ph = np.take(dens_b, tables.grid.cell_index(cos_psi[o2]), axis=0)  # (m, B)
                s_o = s[o2]
                inv_s2 = 1.0 / s_o ** 2
                val = F[mv[o2]] * ph * np.exp(-np.outer(s_o - reach, c if every else kappa_cam)) \
                    * (inv_s2 / omega[ir, ic])[:, None]
                kb = np.clip(np.searchsorted(edges, s[o2], side="right") - 1, 0, M - 1)
                who = mv[o2]
                ts_ = touched[who]
                for which, m_ in ((0, ~ts_), (1, ts_)):
                    if np.any(m_):
                        acc.add(which, (bid[who[m_]], li[who[m_]], ir[m_], ic[m_], kb[m_]), val[m_])
                n_vert += o2.size
            if track:
                n_vert += _splat_near(acc, x, F[mv], d_end[mv], None, n_sig[mv], touched[mv], c, b, kappa_cam, track, rng,
                                      bid[mv], li[mv], surf, pupil, reach, near_m, edges, cutoff_cos, dens_b, tables,
                                      cells, turns, hero[mv], P[mv])
            if nee is not None:
                # class B: only connections that make the path class B (after a significant event, or a turn
                # towards the target by more than ψ_c; with the δ-truncation the phase function is 0 within it)
                nee.from_water(irr, x, d_end[mv], F[mv], P[mv], bid[mv], li[mv], c, dens_b, tables, cell_area, rng,
                               after=None if irradiance_only else (n_sig[mv], cutoff_cos))
            # scatter
            cos_new = _sample_phase(tables, weights, hero[mv], rng)
            ph_new = np.take(dens_b, tables.grid.cell_index(cos_new), axis=0)
            if nee is not None:
                last[mv], x_prev[mv], pph[mv] = 1, x, P[mv] * ph_new
            F[mv] *= ph_new
            P[mv] *= ph_new
            norm = P[mv].mean(axis=1, keepdims=True)
            F[mv] /= norm
            P[mv] /= norm
            n_sig[mv] += cos_new < cutoff_cos
            new_pos[mv] = x
            new_dirs[mv] = _rotate(d_end[mv], cos_new, 2 * np.pi * rng.random(mv.size))
        # ---- surfaces: class-B irradiance, then a diffuse reflection
        sv = np.flatnonzero(~med & np.isfinite(t_s))
        if sv.size:
            k = oid[sv] - 1
            x = p[sv] + t_s[sv, None] * d[sv]
            dep = n_sig[sv] >= 1  # one alone (the first event) is the analytic model's direct light
            if only_a:
                dep = ~dep
            nrm = n_hit[sv]
            nrm = np.where((_dot(nrm, d[sv]) > 0)[:, None], -nrm, nrm)  # the lit side
            seen = _dot(nrm, pupil - x) > 0  # the side the camera sees
            if irradiance_only:
                dep = seen
            else:
                # a flat piece's texture is the side the camera sees (a mesh's cells hold both sides): light
                # on its back is not in the picture (until 2026-12-04 it was counted on the front)
                dep &= seen | surf.is_mesh[k]
            if every or qss:
                _splat_surface(veil_s, (bid[sv], li[sv]), x, k, nrm, F[sv], refl, surf, pupil, reach, edges,
                               c if every else kappa_cam, cells)
                dep[:] = False
            if np.any(dep):
                iu, iv = _texture_cell(surf, k[dep], x[dep], nrm[dep])
                wgt = F[sv[dep]]
                if nee is not None:
                    wgt = wgt * nee.hit_weight(last[sv[dep]], x_prev[sv[dep]], pph[sv[dep]], x[dep], nrm[dep], c)[:, None]
                np.add.at(irr, (bid[sv[dep]], li[sv[dep]], k[dep], iu, iv), wgt / cell_area[k[dep], iu, iv, None])
            if nee is not None:
                last[sv] = 2
            if track:
                n_vert += _splat_near(acc, x, F[sv] * refl[k + 1], None, nrm, n_sig[sv], np.ones(sv.size, bool), c, b,
                                      kappa_cam, track, rng, bid[sv], li[sv], surf, pupil, reach, near_m, edges,
                                      cutoff_cos, dens_b, tables, cells, turns, hero[sv], P[sv])
            u1, u2 = rng.random(sv.size), rng.random(sv.size)
            r_ = np.sqrt(u1)
            loc = np.stack([r_ * np.cos(2 * np.pi * u2), r_ * np.sin(2 * np.pi * u2), np.sqrt(1 - u1)], -1)
            F[sv] *= refl[k + 1]
            n_sig[sv] += 1
            touched[sv] = True
            new_pos[sv] = x + 1e-7 * nrm
            new_dirs[sv] = _cosine_about(nrm, loc)
        # ---- ends: escaped, far away, Russian roulette
        dist = _norm(new_pos - pupil)
        far = dist > edges[-1]
        qs = np.minimum(1.0, roulette_importance(F, dist, kappa_cam, free_m) / (ROULETTE_WEIGHT * f_ref))
        keep = (rng.random(n) < qs) & ~far
        F = F[keep] / qs[keep, None]
        P, pos, dirs = P[keep], new_pos[keep], new_dirs[keep]
        hero, n_sig, touched, bid, li, f_ref = hero[keep], n_sig[keep], touched[keep], bid[keep], li[keep], f_ref[keep]
        if nee is not None:
            last, x_prev, pph = last[keep], x_prev[keep], pph[keep]
    acc.flush()
    if classes == "B":
        flu /= vol[None, None, :, :, :, None]
        if S and TARGET_KERNEL_M:
            irr = _smooth_on_targets(irr, surf, cell_area, TARGET_KERNEL_M, TARGET_KERNEL_DEGREE, pupil=pupil)
        veil, veil_s, flu = (_smooth_in_water(a, edges, omega, cells.cell_rad) for a in (veil, veil_s, flu))
    veil, veil_s, flu = (cells.crop(a) for a in (veil, veil_s, flu))
    return _result(veil, veil_s, irr, flu, power, to_bands, edges, cols, rows, width, height, photons, n_vert, t0)


def _target_planes(surf: SceneSurfaces, pupil: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """The flat targets of several pieces in one plane: ``(fitted, evaluated)`` surface indices (0-based) per
    target.  Fitted: its rectangles and disks in one plane that no other piece of it covers (a ColorChecker's
    patches); evaluated: those and its pieces in parallel planes within 1 cm behind them, seen from ``pupil``
    (the chart's body, whose own cells mix its lit gaps with the dark under the patches).  Meshes and targets
    of one piece are left alone."""
    out = []
    key = [lab.split(":")[0] for lab in surf.labels]
    for name in dict.fromkeys(key):
        ks = np.array([k for k in range(len(surf)) if key[k] == name and not surf.is_mesh[k]], np.int64)
        if ks.size < 2:
            continue
        n0 = surf.normal[ks[0]]
        if not np.all(np.abs(surf.normal[ks] @ n0) > 1 - 1e-6):
            continue
        if np.dot(n0, np.asarray(pupil, float) - surf.center[ks[0]]) < 0:
            n0 = -n0
        off = surf.center[ks] @ n0  # along the normal towards the camera: larger is nearer
        covered = np.zeros(ks.size, bool)
        for i, k in enumerate(ks):
            if surf.is_disk[k]:
                continue
            rel = surf.center[ks] - surf.center[k]
            a, b = rel @ surf.u[k], rel @ surf.v[k]
            inside = (np.abs(a) < surf.half_size[k, 0]) & (np.abs(b) < surf.half_size[k, 1])
            covered[i] = np.any(inside & (off - off[i] > 1e-9) & (off - off[i] < 0.01))  # another piece in front
        fit = ks[~covered]
        if fit.size < 2 or np.ptp(off[~covered]) > 1e-6:
            continue
        out.append((fit, ks))
    return out


def _smooth_on_targets(irr: np.ndarray, surf: SceneSurfaces, cell_area: np.ndarray, sigma_m: float,
                       degree: int = 2, *, pupil: np.ndarray) -> np.ndarray:
    """:data:`TARGET_KERNEL_M`: the class-B irradiance ``irr`` (…, S, TEXTURE, TEXTURE, B) of each flat target
    of several pieces (:func:`_target_planes`) replaced, at every texture cell of its pieces, by a local
    polynomial regression of ``degree`` (Gaussian weights of standard deviation ``sigma_m`` in the plane, times
    the cells' areas) over the cells of its uncovered pieces.  A local polynomial, not a plain kernel average:
    the field's gradient (degree 1) and curvature (2) across the target are kept, at its edges too, where a
    kernel average is biased by the side it lacks (Fan & Gijbels 1996, *Local Polynomial Modelling and Its
    Applications*, Chapman & Hall).  Linear in ``irr`` (but for a floor at zero): the batches' mean stays the
    mean of the smoothed batches."""
    groups = _target_planes(surf, pupil)
    if not groups:
        return irr
    out = irr.copy()
    g = (np.arange(TEXTURE) + 0.5) / TEXTURE * 2 - 1
    for fit, ev in groups:
        k0 = fit[0]

        def centres(ks):  # (len(ks) · T², 2) cell centres in the plane (m), about the first fitted piece
            hw, hh = _texture_half_sizes(surf, ks)
            p = (surf.center[ks][:, None, None, :] + (hw[:, None, None, None] * g[None, :, None, None]) * surf.u[ks][:, None, None, :]
                 + (hh[:, None, None, None] * g[None, None, :, None]) * surf.v[ks][:, None, None, :])
            rel = p.reshape(-1, 3) - surf.center[k0]
            return np.stack([rel @ surf.u[k0], rel @ surf.v[k0]], axis=-1)

        xf, xe = centres(fit), centres(ev)
        o = xf.mean(axis=0)
        xf, xe = (xf - o) / sigma_m, (xe - o) / sigma_m  # in kernel widths about the fitted cells' middle

        def basis(x):  # the polynomials of ``degree`` in the plane (the same space about any point)
            cols = [np.ones(len(x)), x[:, 0], x[:, 1]]
            if degree >= 2:
                cols += [x[:, 0] ** 2, x[:, 0] * x[:, 1], x[:, 1] ** 2]
            return np.stack(cols, axis=-1)

        area = cell_area[fit].reshape(-1)
        w_a = np.where(np.isfinite(area), area, 0.0)
        d2 = np.sum(xe ** 2, axis=1)[:, None] + np.sum(xf ** 2, axis=1)[None, :] - 2.0 * xe @ xf.T
        w = w_a[None, :] * np.exp(-0.5 * np.maximum(d2, 0.0))  # (n_eval, n_fit)
        Xf, Xe = basis(xf), basis(xe)  # (n_fit, p), (n_eval, p)
        p = Xf.shape[1]
        M = (w @ (Xf[:, :, None] * Xf[:, None, :]).reshape(-1, p * p)).reshape(-1, p, p)  # Σ_n w X Xᵀ per cell
        M += np.eye(p)[None] * 1e-12 * np.trace(M, axis1=1, axis2=2)[:, None, None]
        r = np.linalg.solve(M, Xe[..., None])[..., 0]  # (n_eval, p): M⁻¹ X(x_e)
        lmat = w * (r @ Xf.T)  # (n_eval, n_fit): the fitted value at each evaluated cell
        lead = irr.shape[:-4]
        src = irr[..., fit, :, :, :].reshape(lead + (fit.size * TEXTURE * TEXTURE, irr.shape[-1]))
        res = np.matmul(lmat, src)
        # (a local fit can dip below zero at an edge where the photons' noise tilts it: no light is negative)
        out[..., ev, :, :, :] = np.maximum(res, 0.0).reshape(lead + (ev.size, TEXTURE, TEXTURE, irr.shape[-1]))
    return out


class _SurfaceNEE:
    """Next-event estimation of the targets' irradiance (``classes="irradiance"``, and class B's from its
    scattering vertices), combined with the photons' own hits by the balance heuristic (Veach & Guibas 1995).

    The hits alone are unbiased, but a chart patch is met by few photons.  Here every scattering vertex ``x``
    (and, for ``classes="irradiance"``, each light's emission point) also sends a flight to a point ``y`` drawn uniformly over the targets'
    sides the camera sees (a surface ∝ its area; density ``1/A`` per unit area, ``A`` their total area); if
    ``y`` is unoccluded and on the seen side it carries ``F_λ p_λ(ψ) e^{−c_λ d} cos θ_y / d²`` (``F`` the
    photon's weight at ``x``, ``p`` the tracer's phase table at the connection's angle ψ, ``d = |y − x|``).
    The photon's own scattering and flight make the same path with density (per unit area at ``y``, averaged
    over the hero bands as the tracer's spectral MIS) ``H = mean_j P_j p_j(ψ) e^{−c_j d} cos θ_y / d²``.
    The weights ``(1/A) / (1/A + H)`` (flight) and ``H / (1/A + H)`` (hit) sum to one on every path, so the
    sum is unbiased; a weighted contribution is ``F p e^{−cd} cos θ_y / d² / (1/A + H)``, at most
    ``F_λ p_λ / mean_j P_j p_j`` — bounded where the phase function is peaked and next to the surface, which
    the hits carry.  The lights' (point lights with the renderer's beam patterns) flights are the only
    estimate of their direct light (the photons' first flights' hits count nothing); after a diffuse
    reflection on a target the hits count fully (no flight is sent from a surface).  Flat pieces only; a
    scene with meshes keeps the hits alone.

    Measured (2026-12-04, ``twin-strobes-45-wide``, ColorChecker, 8 batches, per patch and band; hits' SE /
    combined SE at the same photons; time 1.4–1.6x the hits'): coastal at 1 m, 100 000 photons, 1.4–7
    (patches 15–20 % → 3–6 %: most of their light is the strobes' direct light); Jerlov 9C at 1 m, 200 000,
    ~1.5 (10–30 % → 7–17 %); Jerlov III at 3 m, 200 000, 0.3–7, median ~2 (25–65 % → 9–40 %); a white disk
    1.5 m away in Jerlov 3C ~1.  Where the light on a patch has been scattered forwards many times (most
    of a patch's light there) a photon reaches it only along its own forward-peaked path: the hits carry that
    light and the flights add little; the light-traced reference stays as noisy as the photons reaching
    each patch are few (``benchmarks/bench_reference_hybrid.py``).
    """

    def __init__(self, surf: SceneSurfaces, pupil: np.ndarray):
        hw, hh = surf.half_size[:, 0], surf.half_size[:, 1]
        area = np.where(surf.is_disk, np.pi * hw ** 2, 4.0 * hw * hh)
        self.surf = surf
        self.area_m2 = float(area.sum())
        self.cdf = np.cumsum(area) / area.sum()
        side = np.sign(_dot(surf.normal, pupil[None, :] - surf.center))
        self.n_seen = surf.normal * np.where(side == 0, 1.0, side)[:, None]

    def _connect(self, x: np.ndarray, rng):
        """Points drawn on the targets for vertices ``x`` (n, 3): ``(i, k, y, d, w, cos_y)`` of those that see
        their point unoccluded from its seen side (``i`` their indices in ``x``; ``w`` unit x → y)."""
        surf = self.surf
        n = len(x)
        k = np.minimum(np.searchsorted(self.cdf, rng.random(n), side="right"), len(self.cdf) - 1)
        u1, u2 = rng.random(n), rng.random(n)
        disk = surf.is_disk[k]
        r = np.where(disk, np.sqrt(u1), 1.0)
        a = np.where(disk, r * np.cos(2 * np.pi * u2), 2 * u1 - 1) * surf.half_size[k, 0]
        b = np.where(disk, r * np.sin(2 * np.pi * u2) * surf.half_size[k, 0], (2 * u2 - 1) * surf.half_size[k, 1])
        y = surf.center[k] + a[:, None] * surf.u[k] + b[:, None] * surf.v[k]
        v = y - x
        d = _norm(v)
        w = v / np.maximum(d, 1e-300)[:, None]
        cos_y = -_dot(self.n_seen[k], w)
        i = np.flatnonzero((cos_y > 0) & (d > 1e-9))
        if i.size:
            t, oid = cast_rays(surf, x[i], w[i])
            vis = (oid == k[i] + 1) & (np.abs(t - d[i]) <= 1e-6 * (1.0 + d[i]))
            i = i[vis]
        return i, k[i], y[i], d[i], w[i], cos_y[i]

    def _deposit(self, irr, bid, li, k, y, val, cell_area) -> None:
        iu, iv = _texture_cell(self.surf, k, y, self.n_seen[k])
        np.add.at(irr, (bid, li, k, iu, iv), val / cell_area[k, iu, iv, None])

    def from_lights(self, irr, lights, li, bid, pos, F, c, cell_area, rng) -> None:
        """Each photon's light sends one flight to the targets (its own direct light, the photons' first
        flights count nothing): ``F f(θ)/Ω e^{−c d} cos θ_y / d² · A`` (``f`` the beam pattern, ``Ω`` its solid
        angle: the radiant intensity per unit of emitted power)."""
        i, k, y, d, w, cos_y = self._connect(pos, rng)
        for l, light in enumerate(lights):
            m = li[i] == l
            if not np.any(m):
                continue
            aim = np.asarray(light.aim, float)
            aim = aim / np.linalg.norm(aim)
            theta = np.arccos(np.clip(w[m] @ aim, -1.0, 1.0))
            f = np.asarray(light.beam.relative_intensity(theta), float) / beam_solid_angle_sr(light.beam)
            val = F[i[m]] * np.exp(-np.outer(d[m], c)) * (f * cos_y[m] / d[m] ** 2 * self.area_m2)[:, None]
            self._deposit(irr, bid[i[m]], li[i[m]], k[m], y[m], val, cell_area)

    def from_water(self, irr, x, d_in, F, P, bid, li, c, dens_b, tables, cell_area, rng, after=None) -> None:
        """Scattering vertices ``x`` (photons arriving along ``d_in`` with weights ``F``, hero densities ``P``)
        send one flight each, weighted by the balance heuristic against the hits.  ``after``: ``(n_sig,
        cutoff_cos)`` to count only the flights whose path is class B at the target (a significant event before
        ``x``, or the turn at ``x`` by more than ψ_c); None: every flight."""
        i, k, y, d, w, cos_y = self._connect(x, rng)
        if after is not None and i.size:
            n_sig, cutoff_cos = after
            keep = (n_sig[i] >= 1) | (_dot(d_in[i], w) < cutoff_cos)
            i, k, y, d, w, cos_y = i[keep], k[keep], y[keep], d[keep], w[keep], cos_y[keep]
        if not i.size:
            return
        ph = np.take(dens_b, tables.grid.cell_index(_dot(d_in[i], w)), axis=0)
        T = np.exp(-np.outer(d, c))
        g = cos_y / d ** 2
        H = np.mean(P[i] * ph * T, axis=1) * g
        val = F[i] * ph * T * (g / (1.0 / self.area_m2 + H))[:, None]
        self._deposit(irr, bid[i], li[i], k, y, val, cell_area)

    def hit_weight(self, last, x_prev, pph, y, nrm, c) -> np.ndarray:
        """Balance-heuristic weight of photons' hits at ``y`` (lit-side normals ``nrm``) whose last event was
        ``last`` (0 the light: 0; 2 a surface: 1; 1 a scattering at ``x_prev``, whose ``P_j p_j(ψ)`` is
        ``pph``: ``H / (1/A + H)``)."""
        v = y - x_prev
        d = np.maximum(_norm(v), 1e-300)
        g = np.abs(_dot(nrm, v)) / d ** 3
        H = np.mean(pph * np.exp(-np.outer(d, c)), axis=1) * g
        w = H / (1.0 / self.area_m2 + H)
        return np.where(last == 0, 0.0, np.where(last == 2, 1.0, w))


class _Accumulator:
    """Sums of splats into the veils (batch, light, row, col, range bin, band), by flat index and
    :func:`numpy.bincount` once at the end (``np.add.at`` over five indices at every bounce is
    several times slower)."""

    def __init__(self, veil: np.ndarray, veil_s: np.ndarray, fluence: np.ndarray | None = None):
        self.arrays = (veil, veil_s) + (() if fluence is None else (fluence,))
        self.parts: tuple[list, ...] = tuple([] for _ in self.arrays)

    def add(self, which: int, index: tuple[np.ndarray, ...], val: np.ndarray) -> None:
        self.parts[which].append((np.ravel_multi_index(index, self.arrays[which].shape[:-1]), val))

    def flush(self) -> None:
        for arr, parts in zip(self.arrays, self.parts):
            if not parts:
                continue
            idx = np.concatenate([i for i, _ in parts])
            val = np.concatenate([v for _, v in parts])
            flat = arr.reshape(-1, arr.shape[-1])
            for j in range(arr.shape[-1]):
                flat[:, j] += np.bincount(idx, weights=val[:, j], minlength=flat.shape[0])
            parts.clear()


def _equiangular(p0, dd, t0, t1, pupil, r_out, K, rng):
    """``K`` stratified points on each segment ``p0 + t dd``, ``t0 ≤ t ≤ t1``, outside the ball of radius
    ``r_out`` about ``pupil``, by equiangular sampling about the pupil (Kulla & Fajardo 2012: density
    ∝ 1/s², s the distance to the pupil).  Returns ``(seg, t, weight)``: the segment of each point, its
    ``t`` and ``θ / (h K)`` (1/m; θ the angle the sampled pieces subtend, h the segment's distance from
    the pupil): ``∫ f dt ≈ Σ_k f(t_k) s_k² θ / (h K)``."""
    rel = pupil - p0
    delta = _dot(rel, dd)  # t of the closest approach to the pupil
    h = np.maximum(_norm(rel - delta[:, None] * dd), 1e-9)
    w = np.sqrt(np.maximum(r_out * r_out - h * h, 0.0))  # half-chord inside the excluded ball
    # the pieces [t0, Δ−w] and [Δ+w, t1], as angles about the pupil
    lo1, hi1 = t0, np.minimum(delta - w, t1)
    lo2, hi2 = np.maximum(delta + w, t0), t1
    a0, a1 = np.arctan2(lo1 - delta, h), np.arctan2(hi1 - delta, h)
    b0, b1 = np.arctan2(lo2 - delta, h), np.arctan2(hi2 - delta, h)
    m1 = np.where(hi1 > lo1, a1 - a0, 0.0)
    m2 = np.where(hi2 > lo2, b1 - b0, 0.0)
    theta = m1 + m2
    m = len(p0)
    u = (np.arange(K)[None, :] + rng.random((m, K))) / K * theta[:, None]  # stratified in angle
    ang = np.where(u < m1[:, None], a0[:, None] + u, b0[:, None] + (u - m1[:, None]))
    tk = (delta[:, None] + h[:, None] * np.tan(ang)).ravel()
    seg = np.repeat(np.arange(m), K)
    keep = np.repeat(theta > 0, K) & (tk >= np.repeat(t0, K)) & (tk <= np.repeat(t1, K))
    seg, tk = seg[keep], tk[keep]
    return seg, tk, (theta / (h * K))[seg]


def _splat_points(acc, which, x, d_seg, wgt, kappa_cam, pupil, reach, r_max, cutoff_cos, dens_b, tables,
                  cells: _Cells, who_b, who_l, edges, b=None) -> int:
    """Splat the light scattered towards the camera at points ``x`` (n, 3) of flights in directions
    ``d_seg``: ``wgt`` (n, B) times the phase function towards the camera, the camera leg and 1/ω of
    the cell (``wgt`` holds every other factor, the 1/s² of the splat cancelled by the sampling).
    With ``b`` (B,) the points' ``wgt / b`` — the flights' own weight per unit length (their track
    length) — times the diffuse sphere's phase function towards the camera also go to the particles'
    light (every direction; divided by the cells' volumes at the end: :attr:`MultipleScattering.fluence`)."""
    v = pupil - x
    s = _norm(v)
    cos_psi = _dot(d_seg, v) / np.maximum(s, 1e-12)
    track = b is not None and len(acc.arrays) > 2
    ok = np.flatnonzero((s > reach) & (s < r_max) & ((cos_psi < cutoff_cos) | track))
    if not ok.size:
        return 0
    inside, ir, ic = cells.of(x[ok])
    ok = ok[inside]
    if not ok.size:
        return 0
    kb = np.clip(np.searchsorted(edges, s[ok], side="right") - 1, 0, len(edges) - 2)
    if track:  # what a diffuse sphere there sends to the camera per unit cross-section and reflectance
        # (the points were drawn ∝ 1/s² about the pupil, which the veil's own 1/s² cancels: here s² is put back)
        acc.add(2, (who_b[ok], who_l[ok], ir, ic, kb),
                wgt[ok] / np.maximum(b, 1e-300)[None, :] * (lambert_sphere_phase(cos_psi[ok]) * s[ok] ** 2)[:, None])
        wide = cos_psi[ok] < cutoff_cos
        ok, ic, ir, kb = ok[wide], ic[wide], ir[wide], kb[wide]
        if not ok.size:
            return 0
    ph = np.take(dens_b, tables.grid.cell_index(cos_psi[ok]), axis=0)  # (m, B)
    val = wgt[ok] * ph * np.exp(-np.outer(s[ok] - reach, kappa_cam)) / cells.omega[ir, ic][:, None]
    wh = which[ok]
    for k_, m_ in ((0, ~wh), (1, wh)):
        if np.any(m_):
            acc.add(k_, (who_b[ok][m_], who_l[ok][m_], ir[m_], ic[m_], kb[m_]), val[m_])
    return int(ok.size)


def _splat_track(acc, who, ell, p, d, F, P, c, b, kappa_cam, K, rng, bid, li, touched, pupil, reach, near_m, edges,
                 cutoff_cos, dens_b, tables, cells: _Cells, turns: ConeTurns | None = None,
                 hero: np.ndarray | None = None) -> int:
    """The class-B veil along the coming free flights of photons ``who`` (each after a significant
    event), of length ``ell`` (to the next scattering or surface), outside the near zone: the
    track-length estimator ``∫_0^ℓ b_λ T_λ(t) g_λ(t) dt / Pr(flight ≥ t)`` of the light scattered
    towards the camera (Spanier & Gelbard 1969; with the spectral MIS the survival probability is
    ``mean_j P_j T_j(t)``), at ``K`` points per flight by equiangular sampling about the entrance pupil
    (:func:`_equiangular`): every flight scores, not only its end.  Points behind a target are not
    tested for occlusion: :meth:`MultipleScattering.veil_at` stops each pixel's veil at its own range.
    Returns the points splatted."""
    ell = np.minimum(ell[who], edges[-1])  # a flight to infinity ends at the far edge of the range bins
    seg, tk, geo = _equiangular(p[who], d[who], np.zeros(who.size), ell, pupil, near_m, K, rng)
    if not seg.size:
        return 0
    g = who[seg]
    T = np.exp(-np.outer(tk, c))
    d_at = d[g]
    if turns is None:
        surv = np.mean(P[g] * T, axis=1, keepdims=True)  # the MIS survival probability to t over the heroes
        wgt = F[g] * b[None, :] * T / surv * geo[:, None]
    else:  # the direction at the point after the cone's turns on the way (:class:`ConeTurns`)
        d_at, R, shape = turns.deflect(d[g], tk, hero[g], rng)
        wgt = F[g] * R * shape * b[None, :] * T / np.mean(P[g] * R * T, axis=1, keepdims=True) * geo[:, None]
    return _splat_points(acc, touched[g], p[g] + tk[:, None] * d[g], d_at, wgt, kappa_cam, pupil, reach, edges[-1],
                         cutoff_cos, dens_b, tables, cells, bid[g], li[g], edges,
                         b=b)


def sample_disc_directions(x: np.ndarray, pupil: np.ndarray, axis: np.ndarray, radius_m: float, rng) -> np.ndarray:
    """Unit directions from points ``x`` (n, 3) towards points of the disc of ``radius_m`` about ``pupil``
    facing them (normal ``axis``, the unit vectors from ``x`` to the pupil), at a distance ρ from the
    pupil uniform in [0, radius_m] and an azimuth uniform (:data:`NEAR_AIM_RADIUS_M`; density
    :func:`disc_direction_pdf`)."""
    helper = np.where(np.abs(axis[:, 0:1]) < 0.9, np.array([[1.0, 0.0, 0.0]]), np.array([[0.0, 1.0, 0.0]]))
    e1 = _cross(axis, helper)
    e1 /= _norm(e1)[:, None]
    e2 = _cross(axis, e1)
    rho, phi = radius_m * rng.random(len(x)), 2 * np.pi * rng.random(len(x))
    v = pupil + rho[:, None] * (np.cos(phi)[:, None] * e1 + np.sin(phi)[:, None] * e2) - x
    return v / _norm(v)[:, None]


def disc_direction_pdf(om: np.ndarray, D: np.ndarray, axis: np.ndarray, x: np.ndarray, pupil: np.ndarray,
                       radius_m: float) -> np.ndarray:
    """Solid-angle density (1/sr) of :func:`sample_disc_directions` for directions ``om`` from ``x`` (at
    distance ``D`` from the pupil): where the ray crosses the disc's plane at t, ρ from the pupil,
    ``t² / (cos γ · 2π ρ R)`` (γ its angle to the disc's normal; the area density of the point is
    1/(2π ρ R)); 0 off the disc."""
    cg = _dot(om, axis)
    t = np.where(cg > 1e-9, D / np.maximum(cg, 1e-9), np.inf)
    rho = _norm(x + np.where(np.isfinite(t), t, 0.0)[:, None] * om - pupil)
    on = np.isfinite(t) & (rho < radius_m) & (D > radius_m)
    return np.where(on, np.where(np.isfinite(t), t, 0.0) ** 2 /
                    (np.maximum(cg, 1e-9) * 2 * np.pi * np.maximum(rho, 1e-12) * radius_m), 0.0)


def _splat_near(acc, x, wgt_out, d_in, normal, n_sig, touched, c, b, kappa_cam, K, rng, who_b, who_l, surf, pupil, reach,
                near_m, edges, cutoff_cos, dens_b, tables, cells: _Cells, turns: ConeTurns | None = None,
                hero: np.ndarray | None = None, P_in: np.ndarray | None = None) -> int:
    """The class-B veil of the near zone (within ``near_m`` of the pupil, :data:`NEAR_ZONE_M`): from
    each scattering vertex (``d_in`` its photon's direction) or surface hit (``normal`` its lit side)
    at ``x`` with weight ``wgt_out`` (n, B), one flight aimed at the zone (a direction uniform in the
    cone that holds it, or over the sphere from inside it, or — :data:`NEAR_AIM_FRACTION` of them —
    towards the disc about the pupil, :func:`sample_disc_directions`), weighted by the phase function (or
    ``cos/π`` of the diffuse surface) over that direction's density in the mixture (balance heuristic), and its veil inside the zone
    integrated with exact transmittance ``e^{−c t}`` by equiangular points (the expectation over the
    photon's next direction and free flight of what its own flight would score there: next-event
    estimation of a flight, as photon beams gather a beam's light; Jarosz et al. 2011).  Flights
    blocked by a target before the zone, and points beyond the first surface, do not count.  With ``turns``
    (the δ-truncated cone's; ``hero`` (n,) the photons' hero bands, ``P_in`` (n, B) their paths' densities for
    each hero, normalised) the flights bend as the photons' own do."""
    rel = pupil - x
    D = _norm(rel)
    axis = rel / np.maximum(D, 1e-12)[:, None]
    inside = D < near_m
    cos_a = np.where(inside, -1.0, np.sqrt(np.clip(1.0 - (near_m / np.maximum(D, 1e-12)) ** 2, 0.0, 1.0)))
    n = len(x)
    mu = 1.0 - rng.random(n) * (1.0 - cos_a)
    om = _rotate(axis, mu, 2 * np.pi * rng.random(n))
    # the second strategy: towards a point of the disc about the pupil (NEAR_AIM_*), for the vertices
    # outside it (from inside the disc's reach the sphere is sampled uniformly anyway)
    r_aim = min(NEAR_AIM_RADIUS_M, near_m)
    can_aim = D > r_aim
    ia = np.flatnonzero(can_aim & (rng.random(n) < NEAR_AIM_FRACTION))
    if ia.size:
        om[ia] = sample_disc_directions(x[ia], pupil, axis[ia], r_aim, rng)
    p_cone = np.where(_dot(om, axis) >= cos_a - 1e-12, 1.0 / (2 * np.pi * (1.0 - cos_a)), 0.0)  # 1/sr
    p_disc = disc_direction_pdf(om, D, axis, x, pupil, r_aim)
    pdf = np.where(can_aim, (1.0 - NEAR_AIM_FRACTION) * p_cone + NEAR_AIM_FRACTION * p_disc, p_cone)
    if d_in is not None:
        cos_s = _dot(d_in, om)
        f = np.take(dens_b, tables.grid.cell_index(cos_s), axis=0)  # (n, B) phase, 1/sr
        sig = n_sig + (cos_s < cutoff_cos)
    else:
        cos_o = _dot(normal, om)
        f = np.where(cos_o > 0, cos_o, 0.0)[:, None] / np.pi * np.ones((1, wgt_out.shape[1]))
        sig = n_sig + 1
    use = np.flatnonzero((sig >= 1) & np.any(f > 0, axis=1))
    if not use.size:
        return 0
    x, om, D, f, pdf, rel = x[use], om[use], D[use], f[use], pdf[use], rel[use]
    dl = _dot(rel, om)
    disc = np.sqrt(np.maximum(dl * dl - D * D + near_m * near_m, 0.0))
    t0, t1 = np.maximum(dl - disc, 0.0), dl + disc
    if len(surf):
        eps = 1e-7 * (normal[use] if normal is not None else 0.0)
        t_s, _ = cast_rays(surf, x + eps, om)
        t1 = np.minimum(t1, t_s)
    seg, tk, geo = _equiangular(x, om, t0, np.maximum(t1, t0), pupil, reach, K, rng)
    if not seg.size:
        return 0
    T = np.exp(-np.outer(tk, c))
    wgt = (wgt_out[use][seg] * f[seg] / pdf[seg, None]) * b[None, :] * T * geo[:, None]
    d_at = om[seg]
    if turns is not None:
        # the cone's turns on the way to each point (:class:`ConeTurns`): the point keeps its place on the
        # line, its direction is the bent path's there; the turns' spectral weights balanced over the heroes
        # as the photons' own are
        d_at, R, shape = turns.deflect(om[seg], tk, hero[use][seg], rng)
        wgt *= R * shape / np.mean(P_in[use][seg] * R, axis=1, keepdims=True)
    return _splat_points(acc, touched[use][seg], x[seg] + tk[:, None] * om[seg], d_at, wgt, kappa_cam, pupil, reach,
                         near_m, cutoff_cos, dens_b, tables, cells,
                         who_b[use][seg], who_l[use][seg], edges, b=b)


def _smooth_in_water(veil: np.ndarray, edges: np.ndarray, omega: np.ndarray, cell_rad: float | None = None
                     ) -> np.ndarray:
    """Blur each range bin of ``veil`` (…, rows, cols, bins, bands) across the image by
    :data:`KERNEL_M` at the bin's distance, at most :data:`KERNEL_MAX_CELLS` cells (a mean weighted by the
    cells' solid angles ``omega``; beyond the grid's edges the outer cells are repeated: give the grid
    :data:`GRID_PAD` cells beyond the image, :class:`_Cells`).  ``cell_rad``: a cell's angular size (rad;
    default the square root of the median of ``omega``)."""
    from scipy.ndimage import gaussian_filter

    rows, cols = omega.shape
    if rows * cols == 1:
        return veil
    cell = float(np.sqrt(np.median(omega))) if cell_rad is None else float(cell_rad)  # rad
    s_mid = np.sqrt(edges[:-1] * edges[1:])
    out = veil.copy()
    lead = veil.ndim - 4
    w = omega[(None,) * lead + (slice(None), slice(None), None)]
    for k, s in enumerate(s_mid):
        sigma = min(KERNEL_M / s / cell, KERNEL_MAX_CELLS)
        if sigma < 0.3:
            break  # the rest (farther) would not change
        sig = (0,) * lead + (sigma, sigma, 0)
        num = gaussian_filter(veil[..., k, :] * w, sig, mode="nearest")
        den = gaussian_filter(np.broadcast_to(w, num.shape[:-1] + (1,)).astype(float), sig, mode="nearest")
        out[..., k, :] = num / den
    return out


def _spectral_nodes(wl: np.ndarray, nodes: int | None) -> tuple[np.ndarray, np.ndarray]:
    """The wavelengths the photons carry (nm) and the (bands, nodes) matrix of linear interpolation."""
    if nodes is None or nodes >= len(wl) or len(wl) < 3:
        return wl, np.eye(len(wl))
    wn = np.linspace(float(wl.min()), float(wl.max()), max(2, int(nodes)))
    eye = np.eye(len(wn))
    return wn, np.stack([np.interp(wl, wn, eye[j]) for j in range(len(wn))], axis=1)


def _at_nodes(x: np.ndarray, wl: np.ndarray, wn: np.ndarray) -> np.ndarray:
    x = np.asarray(x, float)
    return x if len(wn) == len(wl) and np.array_equal(wn, wl) else np.interp(wn, wl, x)


def _splat_surface(veil, who, x, k, lit, F, refl, surf, pupil, reach, edges, c, cells: _Cells):
    """``classes="all"``: the light a surface hit reflects towards the camera, splatted like the veil
    (``lit``: the normal of the side the light met)."""
    v = pupil - x
    s = _norm(v)
    wv = v / s[:, None]
    cos_out = _dot(lit, wv)
    ok = (cos_out > 0) & (s > reach) & (s < edges[-1])
    o = np.flatnonzero(ok)
    if o.size:
        blocked = occluded(surf, x[o] + 1e-7 * lit[o], pupil, exclude=k[o] + 1)
        o = o[~blocked]
    if not o.size:
        return
    inside, ir, ic = cells.of(x[o])
    o = o[inside]
    val = F[o] * refl[k[o] + 1] * (cos_out[o] / np.pi)[:, None] * np.exp(-np.outer(s[o] - reach, c)) \
        / (s[o] ** 2 * cells.omega[ir, ic])[:, None]
    kb = np.clip(np.searchsorted(edges, s[o], side="right") - 1, 0, veil.shape[4] - 1)
    np.add.at(veil, (who[0][o], who[1][o], ir, ic, kb), val)


def _cosine_about(n: np.ndarray, loc: np.ndarray) -> np.ndarray:
    """Local (z = normal) directions to world for many normals (frame of Duff et al. 2017)."""
    sign = np.where(n[:, 2] >= 0, 1.0, -1.0)
    a = -1.0 / (sign + n[:, 2])
    bb = n[:, 0] * n[:, 1] * a
    t = np.stack([1.0 + sign * n[:, 0] ** 2 * a, sign * bb, -sign * n[:, 0]], -1)
    s = np.stack([bb, sign + n[:, 1] ** 2 * a, -n[:, 1]], -1)
    return loc[:, 0:1] * t + loc[:, 1:2] * s + loc[:, 2:3] * n


def _batch_noise(totals: np.ndarray) -> float:
    """Standard error of the mean of independent batches' totals over that mean (NaN with fewer than two
    batches, 0 where the mean is not positive): :attr:`MultipleScattering.relative_noise`."""
    if len(totals) < 2:
        return float("nan")
    mu = totals.mean()
    return float(totals.std(ddof=1) / np.sqrt(len(totals)) / mu) if mu > 0 else 0.0


def _result(veil, veil_s, irr, flu, power, to_bands, edges, cols, rows, width, height, photons, n_vert,
            t0) -> MultipleScattering:
    """Batches (nb, L, …, nodes) per light and unit power → the image's bands, times each light's
    spectrum (``power`` (L, bands)), summed over the lights; the batches' mean and noise."""

    def to_image(a):  # (nb, L, ..., n) → (nb, ..., bands)
        return np.einsum("bl...n,kn,lk->b...k", a, to_bands, power, optimize=True)

    veil, veil_s, irr, flu = to_image(veil), to_image(veil_s), to_image(irr), to_image(flu)
    nb = veil.shape[0]
    mean_v = veil.mean(axis=0)  # each batch is an estimate (its photons carry 1/per_batch)
    mean_s = veil_s.mean(axis=0)
    mean_i = irr.mean(axis=0)

    def rel_noise(a):
        return _batch_noise(a.reshape(nb, -1).sum(axis=1))

    def cumulative(m, axis=2):  # along the range bins (axis 2, or 3 with a batch axis), from 0
        return np.concatenate([np.zeros_like(np.take(m, [0], axis=axis)), np.cumsum(m, axis=axis)], axis=axis)

    cell_col = (np.arange(cols) + 0.5) * width / cols
    cell_row = (np.arange(rows) + 0.5) * height / rows
    batches = None
    if nb >= 2:  # each batch's own arrays, for the photons' noise in what is measured on the image
        batches = tuple(np.asarray(a, np.float32) for a in (cumulative(veil, 3), cumulative(veil_s, 3), irr, flu))
    return MultipleScattering(cumulative(mean_v), cumulative(mean_s), edges, cell_col, cell_row, mean_i,
                              flu.mean(axis=0), (rel_noise(veil + veil_s), rel_noise(irr)), int(photons), int(n_vert),
                              time.perf_counter() - t0, batches)
