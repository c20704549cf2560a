"""``rigsim_vol``: a volumetric path tracer for strobe-lit water (equiangular sampling + MIS).

Why
---
With point lights (strobes, video lights) *inside* scattering water, most of the
image is light scattered once near the lights.  Mitsuba's stock ``volpath``
samples scattering distances by transmittance only and connects each scattering
vertex to one light chosen at random, so

* a vertex that lands close to a strobe gets the light's ``1/r²`` unchecked: the
  fireflies that dominate strobe-lit renders (a pixel ~1000× its neighbours);
* its shadow-ray transmittance is a 0/1 track-length estimate, and in a medium
  whose extinction varies with wavelength the distance is drawn for the first
  (hero) wavelength only, so the other wavelengths get unbounded weights
  ``T_i/(σ_t,0 T_0)``.

This integrator removes all three.

Estimator
---------
Each path carries the renderer's four wavelengths.  Along every ray segment
``x(t) = o + t d``, ``0 ≤ t < t_s`` (``t_s``: next surface, or the water's
boundary) the radiance is

    L = ∫₀^{t_s} T(t) σ_s [L_dir(x(t)) + L_ind(x(t))] dt + T(t_s) L_surface,

``T(t) = exp(−σ_t t)`` per wavelength.  ``L_dir`` is the light of the point lights
(``Σ_k p(ψ_k) T(r_k) V_k I_k(ω)/r_k²``; delta lights, reachable only by next-event
estimation), ``L_ind`` everything else.

* **Distance sampling with spectral MIS over whole paths** (one sample per segment):
  a hero wavelength ``h`` of the path, drawn once, drives ``t ~ σ_t,h exp(−σ_t,h t)``;
  the density used is the mixture over the four possible heroes weighted by their
  posterior given the path so far, ``p_d(t) = Σ_j π_j σ_t,j T_j(t)`` with
  ``π_j ∝ Π_{earlier segments} p_j`` (``P_s = Σ_j π_j T_j(t_s)`` to reach the surface).
  The path's weight is then ``f_i / (¼ Σ_j Π p_j)``: bounded by 4 × albedo products
  for every wavelength over the *whole* path (per-segment averaging bounds each
  segment's factor by ``4 albedo`` but lets the product grow as ``4ⁿ``; volpath's
  single-wavelength pdf bounds nothing).
* **Continuation vertex** (``equiangular_vertex``, 0.05 after the first bounce, 0 on
  camera rays): the vertex the path continues from is drawn from the one-sample
  mixture of the distance sample and the equiangular samples, density
  ``(1 − ε) p_d(t) + ε/K Σ_k p_e,k(t)``.  A scattered ray that passes close to a light
  would otherwise put distance-sampled vertices next to it, whose own in-scattered
  light is ``∝ 1/r``.
* **Equiangular sampling** (Kulla & Fajardo 2012) toward *each* point light ``k`` on
  *every* segment (camera rays and scattered rays): with ``Δ = (p_k − o)·d`` and
  ``D`` the distance of the light from the ray line,
  ``t = Δ + D tan(θ_a + ξ (θ_b − θ_a))``, ``θ_a = atan(−Δ/D)``,
  ``θ_b = atan((t_e − Δ)/D)``, density ``p_e(t) = D / ((θ_b − θ_a)(D² + (t − Δ)²))``
  on ``[0, t_e]``, ``t_e = min(t_s, t_cap)`` (``t_cap = 30/min_i σ_t,i``: beyond it all
  wavelengths' transmittance is < 1e-13 and the distance technique alone covers it).
  As ``D² + (t − Δ)² = r²``, ``σ_s T I/r² / p_e ∝ 1/D``: the ``1/r²`` singularity
  is gone.
* **MIS**: ``L_dir`` of light ``k`` on the segment is estimated by both techniques
  (the distance sample and the equiangular sample, each connected to the light by
  an analytic, exact transmittance ``exp(−σ_t r)`` and a shadow ray) and combined
  with the power heuristic (Veach's multi-sample MIS, ``β = 2``; ``mis="balance"``
  for ``β = 1``).  The weights are the same for all wavelengths (they need only sum
  to one), so the estimator is unbiased per wavelength.
* **Light-directed continuation**: a scattered ray (from a medium vertex or a
  surface) that passes a light at distance ``D`` carries in-scattered light ``∝ 1/D``
  (the line integral of ``1/r²``), and ``D`` is small with probability ``∝ D²``: an
  infinite-variance tail (double scattering next to a strobe: the fireflies left by
  plain equiangular sampling).  New directions are therefore drawn from a
  defensive mixture: with probability ``light_directed`` (0.4) around a light, at
  angle α from it uniform in α (density ``1/(2π² sin α)`` ∝ ``1/α``, so ``1/D`` is
  cancelled), otherwise from the phase function (BSDF); the weight is
  ``value / mixture density``.  From depth ``light_directed_depth`` (4: a path's fifth vertex) on the share
  is ``light_directed_deep`` (0.2): a direction drawn from the phase function weighs up to
  ``1/(1 − share)``, and over the tens of vertices of a path in turbid, high-albedo water (in
  Jerlov 9C a fifth of the veil at 450 nm is light scattered ten times or more) the paths that
  keep drawing from the phase function grow like ``1.67ⁿ``: the largest of 2 000 000 camera paths
  over an edge-lit chart at 1 m held 5 % of their sum, its throughput 2.85 at depth 16 (a path's
  mean there is the albedo to the 16th, ~0.04).  Near the camera, where the paths meet the
  strobes' beams, the full share stays.
* **Phase-weighted equiangular angles**: along the segment, the single-scattering
  angle toward the ray's origin is ``ψ = θ + π/2``, so in θ the integrand is the
  phase function itself (over ``D``).  Three quarters of the equiangular samples
  (``phase_weighted`` = 0.75) draw θ from the wavelength-averaged water phase function
  on ``[θ_a, θ_b]``, the rest uniformly (:class:`PhaseAngleTable`); the reported
  density is the mixture's.
* **Aureole directions** (``aureole`` = 0.75 of the light-directed share): in
  forward-scattering water a ray leaving ``x`` at angle α from a light collects
  ``∝ G(α)/(r sin α)``, ``G(α) = ∫_α^π p̄ dψ`` — steeper than ``1/α`` wherever the phase
  function's forward peak is; :class:`AureoleTable` samples α ∝ ``G`` (the rest of the
  light-directed directions stay ∝ ``1/α``).
* **Surfaces** (opaque BSDFs, here rigsim's two-sided diffuse targets): next-event
  estimation to every light with the analytic transmittance, for *every* path whose
  segment ends on the surface, weighted ``β T(t_s)`` (the expectation over whether the
  distance sample reaches it: a target seen through turbid water gets its direct light
  from every camera sample, not from the few that reach it); then, for the paths that
  do reach it, the BSDF/light-directed mixture (point lights are delta: no MIS with BSDF
  sampling needed).
* **Russian roulette**: from depth ``n_a`` on, survive with
  ``q = min(max_i β_i / rr_threshold, 0.95)`` (``rr_threshold`` = 0.05): a path whose
  weight fell to 1e-4 (a direction drawn toward a light where the phase function is
  small) is lifted to 0.05, not to a full-weight path that may then see a strobe.
  ``n_a = ⌈ln(rr_threshold) / ln a⌉`` (``a``: the path's largest single-scattering albedo
  over its four wavelengths), clipped to [``rr_depth``, ``rr_depth_max``] = [5, 20]: the depth
  at which a typical path's throughput ``aⁿ`` has itself fallen to the threshold (coastal-regions
  water, ``a`` ≈ 0.1: 5; Jerlov 9C at 450 nm, 0.82: 16; Jerlov III, 0.97: 20).  Before that,
  the roulette killed typical paths of high-albedo water and lifted the survivors into the
  same bright halos near the strobes the others met: in Jerlov 7C at 3 m (450 nm, camera
  paths over an edge-lit chart, no roulette up to depth 40 against roulette from depth 5) the
  largest path's share of 2 000 000 fell from 0.66 % to 0.19 %.
* **Target next-event estimation** (``target_nee``, on): at the first scattering vertex
  of each camera path, a point uniform by area on the opaque shapes, kept if it is the
  first surface seen from the vertex, brings its direct light (BSDF × every light), combined
  by the power heuristic with the continuation, which reaches the same point with its
  direction density.  In edge-lit water the lit chart is the brightest thing the dark water
  beside it sees, and phase sampling found it only rarely: in the demo's edge-lit coastal
  scene at 1 m the per-pixel error at the 99th percentile fell from 1.03 to 0.76 of the local
  mean and the maximum from 4.9 to 2.6 (two other edge-lit scenes: maxima 3.2 → 2.5 and
  3.2 → 1.7, p99 about equal), for 16–47 % more render time.
* **Halo next-event estimation** (``halo_nee``, on): at every medium vertex, for each
  light, a direction from the :class:`AureoleTable`, a traced segment along it, an
  equiangular sample on it and a shadow ray estimate the light's halo (light scattered
  once more near the strobe) directly, combined by the power heuristic with the
  continuation path, whose next segment weighs that light by the complementary weight.
  Without it the halo comes only from the share of continuations drawn toward a light.
* **Halos seen from surfaces** (``surface_halo``, on): the same estimate from every surface
  hit (weight ``β T(t_s)``, like the surface's direct light) and from the target point of the
  target NEE, for one light chosen at random; the continuation from the surface weighs that
  light's next segment by the complementary weight.  The strobe's glow is the brightest thing
  a chart sees after the strobe itself, and the surface's light-directed continuations alone
  brought it in few paths with the chart's full halo light: in the dark water beside an
  edge-lit chart those were the fireflies (edge-lit coastal 1 m, 64 spp × 4: per-pixel error
  at the 99th percentile 0.79 → 0.45 of the local mean, maximum 2.4 → 1.6; clear oceanic
  jerlov-II: maxima 56 → 7 and 45 → 4.6), for about 32 % more render time.
* **Backscatter from the same paths** (``backscatter_aov``): the light each path
  gathers before it first meets a surface is the estimate of the pass with black
  targets; it is returned as four AOVs, so the ``backscatter`` layer costs no second
  render.
* **Path classes of the fast engine** (``class_split_deg`` = ψ_c, off by default): the light of the paths
  that meet no surface and turn by more than ψ_c at most once (scattering angles at the water vertices,
  the turn towards the light included) is returned as four more AOVs, ``class_a.0..3``: the fast engine's
  class A (:mod:`rigsim.preview.multiple`), computed by its analytic model; the rest of the image is its
  class B.  Each technique labels its own path (a halo estimate turns twice), so the split is unbiased
  for each class; it lets the fast engine's two parts be checked against Monte Carlo separately
  (``benchmarks/bench_fast_engine_classes.py``).  With the option off nothing of this is traced.
  ``max_depth`` counts vertices as ``volpath`` does
  (1: nothing, since lights cannot be seen; 2: single scattering / direct light).

Every light is connected at every vertex (no random light choice): rigsim passes
hold one to a few lights.  Daylight (:class:`~rigsim.render.daylight.AmbientTables`, via
:meth:`RigsimVolIntegrator.set_ambient`) is added by the daylight integrator
(:mod:`rigsim.render.integrators.daylight`), which this one runs on the same camera ray.

Scenes it accepts (checked, :class:`~rigsim.errors.ConfigError` otherwise)
----------------------------------------------------------------------------
rigsim's render scenes: at most one ``homogeneous`` medium, which surrounds the
camera and every light and surface (the water sphere of
:mod:`rigsim.render.mitsuba_scene`, a shape with a ``null`` BSDF whose interior is
the medium); every other shape is opaque (no ``null`` BSDF, no interior medium,
no area light); every emitter is a point-like delta light (``DeltaPosition``,
e.g. :class:`~rigsim.render.emitter_plugin.BeamPointEmitter`).  A path that reaches
the ``null`` boundary has left the water and ends (there is nothing outside).
Without a medium (the ``clear`` pass) it is a plain path tracer with
next-event estimation.

References
----------
Kulla, C. & Fajardo, M. (2012). Importance sampling techniques for path tracing
in participating media. *Computer Graphics Forum* 31(4), 1519–1528 (EGSR).

Veach, E. & Guibas, L. J. (1995). Optimally combining sampling techniques for
Monte Carlo rendering. *SIGGRAPH '95*, 419–428.

Examples
--------
>>> from rigsim.render.integrators import PLUGIN_NAME
>>> PLUGIN_NAME
'rigsim_vol'

In a scene dict: ``"integrator": {"type": "rigsim_vol", "max_depth": -1, "rr_depth": 5}``.
"""

from __future__ import annotations

import math

from rigsim.errors import ConfigError
from rigsim.render.integrators.common import (
    MIS_HEURISTICS,
    T_CAP_OPTICAL_DEPTH,
    Segment,
    aureole_table,
    channel,
    cone_pdf,
    cone_sample,
    connect_light,
    dot4,
    medium_interaction,
    mis_weight,
    mis_weight_over_pdf,
    phase_angle_table,
    reflects,
    russian_roulette,
    sample_target_point,
    target_table,
    water_phase,
)
from rigsim.render.variant import mitsuba

__all__ = ["RigsimVolIntegrator", "PLUGIN_NAME", "SAMPLING_REVISION", "sampling_defaults"]

mi, dr = mitsuba()

#: Name under which the integrator is registered with Mitsuba.
PLUGIN_NAME = "rigsim_vol"

#: Share of equiangular samples whose angle is drawn from the phase function (the rest: uniform).
DEFAULT_PHASE_WEIGHTED = 0.75
#: Share of scattered directions drawn around the lights (density ∝ 1/angle), the rest from the phase function.
DEFAULT_LIGHT_DIRECTED = 0.4
#: The share from vertex :data:`DEFAULT_LIGHT_DIRECTED_DEPTH` of a path on (see :attr:`RigsimVolIntegrator.cone_deep`).
DEFAULT_LIGHT_DIRECTED_DEEP = 0.2
#: The depth from which :data:`DEFAULT_LIGHT_DIRECTED_DEEP` applies (the loop's ``depth``: segments traced before
#: the vertex; 4 is a path's fifth scattering vertex or surface).
DEFAULT_LIGHT_DIRECTED_DEPTH = 4
#: Russian roulette lifts the throughput of surviving paths to at most this (instead of 1):
#: a path whose weight fell to 1e-4 (a direction drawn toward a light, where the phase
#: function is small) is not boosted to a full-weight path that may then see the light.
DEFAULT_RR_THRESHOLD = 0.05
#: Russian roulette starts at the latest at this depth (see :attr:`RigsimVolIntegrator.rr_depth_max`).
DEFAULT_RR_DEPTH_MAX = 20
#: Share of the light-directed directions drawn from the light's aureole (:class:`AureoleTable`);
#: the rest with density ∝ 1/angle.
DEFAULT_AUREOLE = 0.75
#: Share of scattering vertices (after the first bounce) that continue the path from an
#: equiangular sample instead of the distance sample (one-sample MIS mixture).  0.2 and
#: ``phase_weighted`` 0.75 (were 0.5 and 0.5, chosen before the halo estimates existed, which now
#: bring a light's glow to every vertex): edge-lit ColorChecker at 3 m, 84×56, 6 × 64 paths, three
#: seed sets, noise at the 99th percentile in the noisiest colour 0.73 → 0.56 (jerlov-II) and
#: 0.21 → 0.15 (coastal-regions), +5 % time; close-to-port jerlov-II 3 m 0.26 → 0.17, coastal
#: 3 m 0.076 → 0.063, clear 2 m unchanged.  0.05 since 2026-12-07: a vertex drawn by distance weighs up to
#: albedo / (1 − share), and in high-albedo water that factor compounds over the tens of vertices of a path
#: (as the light-directed share's does, :data:`DEFAULT_LIGHT_DIRECTED_DEEP`); the light-directed directions and
#: the halo estimates already bring a light's glow to every vertex.  ``benchmarks/bench_reference_tail.py
#: --before equiangular_vertex=0.2`` (edge-lit chart, 450 nm, chart pixels, 8 000 000 paths each): relvar × time
#: 0.2 / 0.05 = 1.3× and 1.7× (image, veil) in Jerlov 9C at 1 m, 1.5× and 1.5× in 7C at 3 m, 0.9× and 1.1× in 5C
#: at 3 m, 2.0× and 1.3× in III at 3 m, 0.9× and 0.9× in coastal water at 1 m (albedo ~0.1: the same noise, a
#: path 9 % dearer); means within 1.3 SE.  The turbid references are the ones that cost hours.
DEFAULT_EQUIANGULAR_VERTEX = 0.05
#: The same share on camera rays (they seldom pass close to a light; the distance technique
#: alone keeps every camera sample that reaches a target).
DEFAULT_EQUIANGULAR_VERTEX_CAMERA = 0.0
#: Raised by hand whenever a change to this module alters which samples a render with the default options
#: draws (not what they estimate): kept renders are keyed by it and :func:`sampling_defaults`
#: (:func:`rigsim.study.case.cached_render_dir`), so a study's reference does not mix renders of two samplers.
#: 2: the light-directed share 0.2 from depth 4 and the roulette from the water's albedo (2026-12-05).
#: 3: the equiangular continuation share 0.05 (was 0.2; 2026-12-07).
SAMPLING_REVISION = 3
#: The integrator's attributes that say how it draws samples (its Mitsuba properties, as read by ``__init__``).
_SAMPLING_ATTRS = ("rr_depth", "rr_depth_max", "rr_threshold", "mis", "equiangular", "alpha", "cone", "cone_deep",
                   "cone_depth", "halo", "surface_halo", "target_nee", "aureole", "cont_eq", "cont_eq0")


class RigsimVolIntegrator(mi.SamplingIntegrator):
    """Volumetric path tracer with equiangular light sampling (see the module docstring).

    Mitsuba properties: ``max_depth`` (int, −1: unlimited), ``rr_depth`` and ``rr_depth_max``
    (int, 5 and 20: the earliest and the latest depth Russian roulette starts at),
    ``light_directed_deep`` and ``light_directed_depth`` (0.2 from depth 4),
    ``mis`` (``"power"`` or ``"balance"``), ``equiangular`` (bool, True; False leaves
    distance sampling alone — for comparisons), ``halo_nee``, ``target_nee``,
    ``surface_halo`` (bool, True: the extra next-event estimations), ``light_directed``,
    ``aureole``, ``phase_weighted``, ``equiangular_vertex``, ``rr_threshold`` (shares and
    thresholds, see the module constants).
    """

    def __init__(self, props=None):
        if props is None:
            props = mi.Properties(PLUGIN_NAME)
        mi.SamplingIntegrator.__init__(self, props)
        md = int(props.get("max_depth", -1))
        if md < -1 or md == 0:
            raise ConfigError(f"max_depth must be -1 or >= 1, got {md}", field="integrator.max_depth")
        self.max_depth = md
        self.rr_depth = int(props.get("rr_depth", 5))
        if self.rr_depth < 1:
            raise ConfigError(f"rr_depth must be >= 1, got {self.rr_depth}", field="integrator.rr_depth")
        self.rr_depth_max = int(props.get("rr_depth_max", max(DEFAULT_RR_DEPTH_MAX, self.rr_depth)))
        if self.rr_depth_max < self.rr_depth:
            raise ConfigError(f"rr_depth_max must be >= rr_depth ({self.rr_depth}), got {self.rr_depth_max}",
                              field="integrator.rr_depth_max")
        self.rr_threshold = float(props.get("rr_threshold", DEFAULT_RR_THRESHOLD))
        if not 0.0 < self.rr_threshold <= 1.0:
            raise ConfigError(f"rr_threshold must be in (0, 1], got {self.rr_threshold}",
                              field="integrator.rr_threshold")
        self.mis = str(props.get("mis", "power"))
        if self.mis not in MIS_HEURISTICS:
            raise ConfigError(f"mis must be power or balance, got {self.mis!r}", field="integrator.mis")
        self.equiangular = bool(props.get("equiangular", True))
        self.alpha = float(props.get("phase_weighted", DEFAULT_PHASE_WEIGHTED))
        if not 0.0 <= self.alpha < 1.0:
            raise ConfigError(f"phase_weighted must be in [0, 1), got {self.alpha}",
                              field="integrator.phase_weighted")
        self.cone = float(props.get("light_directed", DEFAULT_LIGHT_DIRECTED))
        if not 0.0 <= self.cone < 1.0:
            raise ConfigError(f"light_directed must be in [0, 1), got {self.cone}",
                              field="integrator.light_directed")
        self.cone_deep = float(props.get("light_directed_deep", min(self.cone, DEFAULT_LIGHT_DIRECTED_DEEP)))
        if not 0.0 <= self.cone_deep <= self.cone:
            raise ConfigError(f"light_directed_deep must be in [0, light_directed = {self.cone}], got {self.cone_deep}",
                              field="integrator.light_directed_deep")
        self.cone_depth = int(props.get("light_directed_depth", DEFAULT_LIGHT_DIRECTED_DEPTH))
        if self.cone_depth < 1:
            raise ConfigError(f"light_directed_depth must be >= 1, got {self.cone_depth}",
                              field="integrator.light_directed_depth")
        self.halo = bool(props.get("halo_nee", True))
        self.surface_halo = bool(props.get("surface_halo", True))
        self.target_nee = bool(props.get("target_nee", True))
        self.aureole = float(props.get("aureole", DEFAULT_AUREOLE))
        if not 0.0 <= self.aureole <= 1.0:
            raise ConfigError(f"aureole must be in [0, 1], got {self.aureole}", field="integrator.aureole")
        # also return, as AOVs, the light of each path before it first meets a surface: the
        # ``backscatter`` pass (targets black) estimated from the same paths, no second render
        self.backscatter_aov = bool(props.get("backscatter_aov", False))
        self.cont_eq = float(props.get("equiangular_vertex", DEFAULT_EQUIANGULAR_VERTEX))
        self.cont_eq0 = float(props.get("equiangular_vertex_camera", DEFAULT_EQUIANGULAR_VERTEX_CAMERA))
        for name, v in (("equiangular_vertex", self.cont_eq), ("equiangular_vertex_camera", self.cont_eq0)):
            if not 0.0 <= v < 1.0:
                raise ConfigError(f"{name} must be in [0, 1), got {v}", field=f"integrator.{name}")
        # the fast engine's class A (see the module docstring) as AOVs: cos ψ_c, or None (off)
        split = props.get("class_split_deg", None)
        if split is not None and not 0.0 <= float(split) <= 180.0:
            raise ConfigError(f"class_split_deg must be in [0, 180], got {split}", field="integrator.class_split_deg")
        self.class_cos = None if split is None else math.cos(math.radians(float(split)))
        self.daylight = None

    def set_ambient(self, tables, world_radius_m: float = 1000.0) -> "RigsimVolIntegrator":
        """Light the scene with a daylight field too (:class:`~rigsim.render.daylight.AmbientTables`, or
        None), added by a :class:`~rigsim.render.integrators.daylight.DaylightIntegrator` on the same rays."""
        from rigsim.render.integrators.daylight import DaylightIntegrator

        self.daylight = None if tables is None else DaylightIntegrator(max_depth=self.max_depth).set_ambient(
            tables, world_radius_m)
        return self

    def sampling(self) -> dict:
        """How this integrator draws samples: its options (:data:`_SAMPLING_ATTRS`) and :data:`SAMPLING_REVISION`."""
        return {"revision": SAMPLING_REVISION, **{k: getattr(self, k) for k in _SAMPLING_ATTRS}}

    @property
    def ambient(self):
        """The daylight field's tables, or None."""
        return None if self.daylight is None else self.daylight.ambient

    # -- scene checks -----------------------------------------------------------------
    def _scene_info(self, scene, medium):
        """(emitters, target table) after checking the scene is one this integrator handles.

        Not cached: ``sample`` runs once per render (it traces the kernel), and keeping the scene
        here would make a reference cycle (scene → integrator → scene) through C++ that Python's
        garbage collector cannot see: every rendered scene stayed alive with its shapes and
        emitters registered, and each indirect call over them (a gathered ``ShapePtr`` or
        ``EmitterPtr``) grew with every scene ever rendered in the process — renders slowed by
        2–5× after a few dozen scenes (the test suite, a dataset, the UI).
        """
        emitters = list(scene.emitters())
        for e in emitters:
            if not mi.has_flag(e.flags(), mi.EmitterFlags.DeltaPosition):
                raise ConfigError(f"{PLUGIN_NAME} handles point lights only, got {type(e).__name__}",
                                  field="integrator", allowed="volpath for other lights")
        if scene.environment() is not None:
            raise ConfigError(f"{PLUGIN_NAME} does not handle environment lights", field="integrator")
        n_null = 0
        for sh in scene.shapes():
            if sh.is_emitter():
                raise ConfigError(f"{PLUGIN_NAME} does not handle area lights ({sh.id()})", field="integrator")
            null = mi.has_flag(sh.bsdf().flags(), mi.BSDFFlags.Null)
            if null:
                n_null += 1
                if medium is None or sh.interior_medium() is None:
                    raise ConfigError(f"{PLUGIN_NAME}: null-BSDF shape {sh.id()!r} is not the water boundary",
                                      field="integrator")
            elif sh.interior_medium() is not None:
                raise ConfigError(f"{PLUGIN_NAME}: shape {sh.id()!r} has an interior medium (only the water "
                                  "boundary may)", field="integrator")
        if n_null > 1:
            raise ConfigError(f"{PLUGIN_NAME} handles one medium boundary, found {n_null}", field="integrator")
        if medium is not None and not medium.is_homogeneous():
            raise ConfigError(f"{PLUGIN_NAME} handles homogeneous media only", field="integrator")
        # the opaque shapes (targets), for next-event estimation of their reflected light from
        # medium vertices: a shape chosen by area, a point uniform on it (density 1/total area)
        return emitters, target_table(scene)

    def mis_weight(self, pdf_a, pdf_b):
        """Weight of technique a against b with this integrator's heuristic (:func:`~.common.mis_weight`)."""
        return mis_weight(pdf_a, pdf_b, self.mis)

    # -- helpers ------------------------------------------------------------------------
    def _directed(self, x, wo, pdf_of, light_pos, aureole, sampler, active, c=None):
        """Mix a default direction with directions drawn around the lights.

        With probability ``1 − c`` (``c = light_directed``) the default direction ``wo`` is
        kept (phase or BSDF sampling, density ``pdf_of(w)``); otherwise a light ``k`` is
        chosen uniformly and the direction is drawn around the axis from ``x`` to it: with
        probability ``h`` (``aureole``) from the light's aureole (:class:`AureoleTable`),
        otherwise at angle α with density ∝ 1/α (:func:`_cone_sample`, which cancels the
        ``1/D`` a ray passing at distance D collects in any water).

        Returns ``(direction, mixture density)``.
        """
        K = len(light_pos)
        c = self.cone if c is None else c
        h = self.aureole if aureole is not None else 0.0
        u_c = sampler.next_1d(active)
        u_a = sampler.next_2d(active)
        use_light = u_c < c
        v = u_c / c * K  # ∈ [0, K) on the light branch: light ⌊v⌋, sub-branch from the fraction
        kc = mi.UInt32(dr.minimum(v, K - 1))
        use_au = (v - mi.Float(kc)) < h
        axes = [dr.normalize(light_pos[k] - x) for k in range(K)]
        for k in range(K):
            pick = use_light & (kc == k)
            wo = dr.select(pick & ~use_au, cone_sample(axes[k], u_a), wo)
            if h > 0:
                wo = dr.select(pick & use_au, aureole.sample(axes[k], u_a.x, u_a.y), wo)
        return wo, self._directed_pdf(wo, pdf_of(wo), axes, aureole, c)

    def _directed_pdf(self, wo, pdf_wo, axes, aureole, c=None):
        """Density of :meth:`_directed` at ``wo`` (``pdf_wo``: the default technique's density
        there, ``axes``: unit directions to the lights)."""
        K = len(axes)
        c = self.cone if c is None else c
        h = self.aureole if aureole is not None else 0.0
        pdf = (1.0 - c) * pdf_wo
        for k in range(K):
            pk = (1.0 - h) * cone_pdf(axes[k], wo)
            if h > 0:
                pk += h * aureole.pdf(axes[k], wo)
            pdf += (c / K) * pk
        return pdf

    # -- Mitsuba interface ----------------------------------------------------------------
    def sample(self, scene, sampler, ray, medium=None, active=True):
        (emitters, targets) = self._scene_info(scene, medium)
        ray = mi.Ray3f(ray)
        active = mi.Bool(active)
        wavelengths = ray.wavelengths
        time = ray.time
        max_depth = self.max_depth if self.max_depth >= 0 else 2**31
        has_medium = medium is not None
        eq = self.equiangular and has_medium

        if has_medium:
            medium_ptr = mi.MediumPtr(medium)
            mei0 = medium_interaction(ray.o, ray.d, mi.Float(0.0), wavelengths, time, medium_ptr)
            sigma_s, _, sigma_t = medium.get_scattering_coefficients(mei0, active)
            sigma_t = mi.Spectrum(sigma_t)
            sigma_s = mi.Spectrum(sigma_s)
            sig_min = dr.minimum(dr.minimum(sigma_t[0], sigma_t[1]), dr.minimum(sigma_t[2], sigma_t[3]))
            t_cap = T_CAP_OPTICAL_DEPTH / dr.maximum(sig_min, 1e-30)
            phase = water_phase(medium.phase_function())
            scatters = dr.any(sigma_s > 0.0)
            table = phase_angle_table(phase) if (eq and self.alpha > 0) else None
            aureole = aureole_table(phase) if self.aureole > 0 else None
            cone = self.cone > 0 and len(emitters) > 0
            halo = self.halo and aureole is not None and eq and cone
            tnee = self.target_nee and targets is not None and len(emitters) > 0
            wbar = table.weights(wavelengths) if table is not None else None
            # Russian roulette starts where a typical path's throughput (the path's largest single-
            # scattering albedo to the power of its depth) has fallen to the roulette threshold, between
            # rr_depth and rr_depth_max (see DEFAULT_RR_DEPTH_MAX)
            rr_start = self.rr_depth
            if self.rr_depth_max > self.rr_depth:
                a_max = dr.max(dr.select(sigma_t > 0, sigma_s / sigma_t, 0.0))
                n_a = dr.ceil(dr.log(self.rr_threshold) / dr.log(dr.clip(a_max, 1e-6, 1.0 - 1e-6)))
                rr_start = mi.UInt32(dr.clip(n_a, self.rr_depth, self.rr_depth_max))
        else:
            sigma_t = None
            tnee = False
            rr_start = self.rr_depth
        light_pos = [e.sample_position(time, mi.Point2f(0.5), active)[0].p for e in emitters]
        bsdf_ctx = mi.BSDFContext()

        def halo_nee(sampler, make_ray, f_pdf_of, axes, axis, p_light, em, active, p_choice=1.0, c=None):
            """A light's halo at a vertex (next-event estimation, without the path weight), and the
            directions of its two turns (leaving the vertex, then towards the light: for the path classes).

            A direction from the light's aureole around ``axis`` (unit, toward ``p_light``), a
            traced segment along it, an equiangular sample on it and a shadow ray to ``em``;
            power-heuristic MIS against the vertex's continuation (:meth:`_directed`), whose
            next segment weighs the light by ``mis_weight(p_cont, p_choice p_aureole)``.
            ``make_ray(w)``: the ray leaving the vertex, ``f_pdf_of(w)``: (phase value or
            BSDF × cosine, the default technique's density), ``axes``: the directions to all
            lights, ``p_choice``: probability that this light was the one chosen.
            """
            w_h = aureole.sample(axis, sampler.next_1d(active), sampler.next_1d(active))
            pa = aureole.pdf(axis, w_h) * p_choice
            f1, f1_pdf = f_pdf_of(w_h)
            pm = self._directed_pdf(w_h, f1_pdf, axes, aureole, c)
            r_h = make_ray(w_h)
            si_h = scene.ray_intersect(r_h, active)
            t_sh = dr.select(si_h.is_valid(), si_h.t, dr.inf)
            seg_h = Segment(r_h.o, w_h, p_light, dr.minimum(t_sh, t_cap), table, wbar, self.alpha)
            t_h, pdf_h = seg_h.sample(sampler.next_1d(active), sampler.next_1d(active), sampler.next_1d(active))
            ok_h = active & (pa > 0) & (pdf_h > 0) & (t_h < t_sh)
            x_h = r_h.o + w_h * t_h
            mei_h = medium_interaction(x_h, w_h, t_h, wavelengths, time, medium_ptr)
            val_h, ds_h = connect_light(scene, mei_h, em, sigma_t, ok_h)
            ph2, _ = phase.eval_pdf(mi.PhaseFunctionContext(sampler), mei_h, ds_h.d, ok_h)
            T_h = dr.exp(-sigma_t * t_h)
            # (value / pa) × MIS weight, in a form that stays finite for tiny pa
            w_over_pa = mis_weight_over_pdf(pa, pm, self.mis)
            c_h = f1 * w_over_pa * (T_h * sigma_s / pdf_h) * ph2 * val_h
            # a product that overflows (inf · 0 in one wavelength; ~4 in 2·10⁶ paths of the
            # demo's jerlov-II cases) is dropped here rather than the whole path sample
            return dr.select(ok_h & dr.all(dr.isfinite(c_h)), c_h, 0.0), (w_h, ds_h.d)

        em_ptrs = mi.EmitterPtr(emitters) if emitters else None

        def pick_light(sampler, axes, active):
            """One light chosen uniformly: (EmitterPtr, axis, position)."""
            K = len(axes)
            k = mi.UInt32(dr.minimum(sampler.next_1d(active) * K, K - 1))
            axis, pos = axes[0], light_pos[0]
            for j in range(1, K):
                axis = dr.select(k == j, axes[j], axis)
                pos = dr.select(k == j, light_pos[j], pos)
            return dr.gather(mi.EmitterPtr, em_ptrs, k, active), axis, pos

        def wide(u, v):
            """1 where the path turns from direction ``u`` to ``v`` by more than the class split angle."""
            return dr.select(dr.dot(u, v) < self.class_cos, mi.UInt32(1), mi.UInt32(0))

        def class_a(clean, nw, c, *turns):
            """``c`` where the path it ends (no surface yet, ``nw`` wide turns so far, then ``turns``) is class A."""
            if self.class_cos is None:
                return 0.0
            n = mi.UInt32(nw)
            for u, v in turns:
                n += wide(u, v)
            return dr.select(clean & (n <= 1), c, 0.0)

        def cond(sampler, active, depth, o, d, beta, L, hero, pw, Lb, clean, hw, qs, Lc, nw):
            return active

        def body(sampler, active, depth, o, d, beta, L, hero, pw, Lb, clean, hw, qs, Lc, nw):
            # ---- termination: depth limit, zero throughput, Russian roulette
            active &= (depth + 1 < max_depth) & dr.any(beta != 0.0)
            c_v = (dr.select(depth < self.cone_depth, mi.Float(self.cone), mi.Float(self.cone_deep))
                   if self.cone_deep != self.cone else None)
            active, beta = russian_roulette(sampler, beta, depth, rr_start, self.rr_threshold, active)

            r = mi.Ray3f(o, d, time, wavelengths)
            si = scene.ray_intersect(r, active)
            t_s = dr.select(si.is_valid(), si.t, dr.inf)
            surf = active & si.is_valid()
            hit = mi.Bool(surf)  # the segment ends on a surface (reached or not by this path)
            beta_hit = mi.Spectrum(beta)  # weight of the surface's direct light: β · T(t_s)
            o_next, d_next = mi.Point3f(o), mi.Vector3f(d)
            cont = mi.Bool(False)

            if has_medium:
                # ---- distance sampling, spectral MIS over the path's wavelengths
                u_t = sampler.next_1d(active)
                t_d = -dr.log(1.0 - u_t) / channel(sigma_t, hero)
                med = active & (t_d < t_s) & scatters
                T_d = dr.exp(-sigma_t * t_d)
                pdf_d = dot4(pw, sigma_t * T_d)
                T_s = dr.exp(-sigma_t * t_s)
                P_s = dot4(pw, T_s)
                beta_hit = beta * T_s
                w_d = dr.select(pdf_d > 0, T_d * sigma_s / pdf_d, 0.0)
                x_d = o + d * t_d
                mei_d = medium_interaction(x_d, d, t_d, wavelengths, time, medium_ptr)
                ctx = mi.PhaseFunctionContext(sampler)
                t_e_max = dr.minimum(t_s, t_cap)

                segs, t_es, ok_es = [], [], []
                for k, em in enumerate(emitters):
                    seg = Segment(o, d, light_pos[k], t_e_max, table, wbar, self.alpha) if eq else None
                    # (1) the distance sample connected to light k
                    val, ds = connect_light(scene, mei_d, em, sigma_t, med)
                    ph_val, _ = phase.eval_pdf(ctx, mei_d, ds.d, med)
                    w = self.mis_weight(pdf_d, seg.pdf(t_d)) if eq else 1.0
                    c_d = dr.select(med, beta * w_d * ph_val * val * (w * hw[k]), 0.0)
                    L += c_d
                    Lb += dr.select(clean, c_d, 0.0)
                    Lc += class_a(clean, nw, c_d, (d, ds.d))
                    if eq:
                        # (2) an equiangular sample toward light k
                        t_e, pdf_e = seg.sample(sampler.next_1d(active), sampler.next_1d(active),
                                                sampler.next_1d(active))
                        ok = active & scatters & (pdf_e > 0) & (t_e < t_s)
                        x_e = o + d * t_e
                        mei_e = medium_interaction(x_e, d, t_e, wavelengths, time, medium_ptr)
                        val_e, ds_e = connect_light(scene, mei_e, em, sigma_t, ok)
                        ph_e, _ = phase.eval_pdf(ctx, mei_e, ds_e.d, ok)
                        T_e = dr.exp(-sigma_t * t_e)
                        pdf_d_e = dot4(pw, sigma_t * T_e)
                        w_e = self.mis_weight(pdf_e, pdf_d_e)
                        c_e = dr.select(ok, beta * (T_e * sigma_s / pdf_e) * ph_e * val_e * (w_e * hw[k]), 0.0)
                        L += c_e
                        Lb += dr.select(clean, c_e, 0.0)
                        Lc += class_a(clean, nw, c_e, (d, ds_e.d))
                        segs.append(seg)
                        t_es.append(t_e)
                        ok_es.append(ok)

                # ---- the vertex the path continues from: a one-sample mixture of the distance
                # sample (share 1 − ε) and the equiangular samples (ε, split evenly over the lights).
                # Its density near a light ∝ 1/r², so the in-scattered light of the next segment
                # (∝ 1/r) stays bounded.  Only the distance technique reaches the surface.
                n_l = len(segs)
                if n_l and (self.cont_eq > 0 or self.cont_eq0 > 0):
                    eps = dr.select(scatters, dr.select(depth == 0, self.cont_eq0, self.cont_eq), 0.0)
                    u_v = sampler.next_1d(active)
                    use_e = u_v < eps
                    kv = mi.UInt32(dr.minimum(u_v / dr.maximum(eps, 1e-12) * n_l, n_l - 1))
                    t_c = mi.Float(t_d)
                    ok_c = mi.Bool(med)
                    for k in range(n_l):
                        pick = use_e & (kv == k)
                        t_c = dr.select(pick, t_es[k], t_c)
                        ok_c = dr.select(pick, ok_es[k], ok_c)
                    T_c = dr.exp(-sigma_t * t_c)
                    p_eq = mi.Float(0.0)
                    for k in range(n_l):
                        p_eq += (eps / n_l) * segs[k].pdf(t_c)
                    pj_c = (1.0 - eps) * sigma_t * T_c + p_eq  # density of t_c for each hero channel j
                    pdf_c = dot4(pw, pj_c)
                    med_c = ok_c
                    surf &= ~use_e & ((t_d >= t_s) | ~scatters)
                    p_surf = (1.0 - eps) * P_s
                    w_med = dr.select(pdf_c > 0, T_c * sigma_s / pdf_c, 0.0)
                    x_c = o + d * t_c
                    mei_c = medium_interaction(x_c, d, t_c, wavelengths, time, medium_ptr)
                else:
                    med_c, x_c, mei_c, p_surf = med, x_d, mei_d, P_s
                    # albedo 0 (the ``direct`` pass): every path goes on to the surface, weight T
                    surf &= (t_d >= t_s) | ~scatters
                    w_med = w_d
                    pj_c, pdf_c = sigma_t * T_d, pdf_d
                beta_surf = dr.select(scatters, dr.select(p_surf > 0, T_s / p_surf, 0.0), T_s)
                med = med_c
                # posterior of the hero channel given the path so far (spectral MIS over whole paths)
                pw_next = dr.select(med, dr.select(pdf_c > 0, pw * pj_c / pdf_c, pw), pw)
                pw_next = dr.select(surf & scatters, dr.select(P_s > 0, pw * T_s / P_s, pw), pw_next)

                # ---- continue from the chosen vertex: phase sampling
                wo, ph_w, ph_pdf = phase.sample(ctx, mei_c, sampler.next_1d(med), sampler.next_2d(med), med)
                if cone:
                    # defensive mixture with directions drawn around each light
                    wo, pdf_mix = self._directed(x_c, wo, lambda w: phase.eval_pdf(ctx, mei_c, w, med)[1],
                                                 light_pos, aureole, sampler, med, c_v)
                    ph_val, _ = phase.eval_pdf(ctx, mei_c, wo, med)
                    ph_w = dr.select(pdf_mix > 0, ph_val / pdf_mix, 0.0)
                    ph_pdf = pdf_mix
                hw_next = [mi.Float(1.0) for _ in emitters]
                qs_next = mi.Float(0.0)
                if tnee:
                    # ---- next-event estimation of the targets' reflected light from the first
                    # scattering vertex of camera paths: a point y uniform on the opaque shapes (by
                    # area), kept if it is the first surface seen from here, its direct light; MIS
                    # (power) against the continuation, which reaches the same y with the direction
                    # density ph_pdf (its surface NEE then carries the complementary weight, see qs).
                    # A lit chart is a bright area source that the dark water beside it otherwise
                    # sees only by phase sampling (only the first vertex: at every vertex it cost
                    # +70 % time for little more gain).
                    deep_t = med & (depth == 0) & (depth + 2 < max_depth)
                    inv_area_t = targets[2]
                    ps_t = sample_target_point(targets, time, sampler.next_1d(deep_t), sampler.next_2d(deep_t),
                                               deep_t)
                    v_t = ps_t.p - x_c
                    dist_t = dr.norm(v_t)
                    ok_t = deep_t & (dist_t > 0)
                    w_t = v_t / dist_t
                    ray_t = mi.Ray3f(x_c, w_t, time, wavelengths)
                    si_t = scene.ray_intersect(ray_t, ok_t)
                    ok_t &= si_t.is_valid() & (dr.abs(si_t.t - dist_t) <= 1e-4 * dist_t + 1e-5)
                    bsdf_t = si_t.bsdf(ray_t)
                    ok_t &= ~mi.has_flag(bsdf_t.flags(), mi.BSDFFlags.Null)
                    cos_t = dr.abs(dr.dot(si_t.n, w_t))
                    p_sa = dr.select(cos_t > 0, inv_area_t * dr.square(si_t.t) / cos_t, 0.0)  # per sr
                    ph_t, p_cont = phase.eval_pdf(ctx, mei_c, w_t, ok_t)
                    if cone:  # the continuation's mixture density at w_t
                        axes_t = [dr.normalize(light_pos[k] - x_c) for k in range(len(emitters))]
                        p_cont = self._directed_pdf(w_t, p_cont, axes_t, aureole, c_v)
                    lit = mi.Spectrum(0.0)
                    for em in emitters:
                        val_t, ds_t = connect_light(scene, si_t, em, sigma_t, ok_t)
                        lit += bsdf_t.eval(bsdf_ctx, si_t, si_t.to_local(ds_t.d), ok_t) * val_t
                    if halo and self.surface_halo:  # and the lights' halos seen from y, as at a surface hit (below)
                        ok_y = ok_t & (depth + 3 < max_depth) & reflects(bsdf_t, bsdf_ctx, si_t, ok_t)
                        axes_y = [dr.normalize(light_pos[k] - si_t.p) for k in range(len(emitters))]
                        em_y, axis_y, pos_y = pick_light(sampler, axes_y, ok_y)
                        lit += halo_nee(sampler, si_t.spawn_ray,
                                        lambda w: bsdf_t.eval_pdf(bsdf_ctx, si_t, si_t.to_local(w), ok_y),
                                        axes_y, axis_y, pos_y, em_y, ok_y, 1.0 / len(emitters), c_v)[0]
                    w_over_p = mis_weight_over_pdf(p_sa, p_cont, self.mis)
                    c_t = beta * w_med * ph_t * dr.exp(-sigma_t * si_t.t) * lit * w_over_p
                    L += dr.select(ok_t & (p_sa > 0) & dr.all(dr.isfinite(c_t)), c_t, 0.0)
                    qs_next = dr.select(deep_t, ph_pdf, 0.0)
                if halo:
                    # ---- next-event estimation of each light's halo from this vertex: a direction
                    # from the aureole table, an equiangular sample on it, a shadow ray; MIS (power)
                    # with the continuation, whose next segment then weighs light k by hw_next[k]
                    axes_c = [dr.normalize(light_pos[k] - x_c) for k in range(len(emitters))]
                    deeper = med & (depth + 2 < max_depth)
                    beta_c = beta * w_med
                    for k, em in enumerate(emitters):
                        pa_cont = aureole.pdf(axes_c[k], wo)
                        hw_next[k] = dr.select(deeper, self.mis_weight(pdf_mix, pa_cont), 1.0)
                        c_h, h_dirs = halo_nee(sampler, lambda w: mi.Ray3f(x_c, w, time, wavelengths),
                                                lambda w: phase.eval_pdf(ctx, mei_c, w, deeper),
                                                axes_c, axes_c[k], light_pos[k], em, deeper, c=c_v)
                        c_h = beta_c * c_h
                        L += c_h
                        Lb += dr.select(clean, c_h, 0.0)
                        Lc += class_a(clean, nw, c_h, (d, h_dirs[0]), h_dirs)
                med &= ph_pdf > 0
                beta = dr.select(med, beta * w_med * ph_w, beta)
                if self.class_cos is not None:
                    nw = dr.select(med, nw + wide(d, wo), nw)
                o_next = dr.select(med, x_c, o_next)
                d_next = dr.select(med, wo, d_next)
                cont |= med
                beta = dr.select(surf, beta * beta_surf, beta)

            # ---- surfaces: the water boundary ends the path; opaque surfaces: NEE + BSDF sampling
            bsdf = si.bsdf(r)
            opaque = ~mi.has_flag(bsdf.flags(), mi.BSDFFlags.Null)
            surf &= opaque
            hit &= opaque
            # direct light on the surface at the end of the segment, for every path (weight β T(t_s):
            # its expected value over whether the distance sample reaches the surface), so that a
            # target seen through turbid water gets it from every camera sample
            w_hit = mi.Float(1.0)
            if tnee:  # against the target NEE made at the segment's origin (if it was a medium vertex)
                cos_h = dr.abs(dr.dot(si.n, d))
                p_sa_h = dr.select(cos_h > 0, targets[2] * dr.square(si.t) / cos_h, 0.0)
                w_hit = dr.select(qs > 0, self.mis_weight(qs, p_sa_h), 1.0)
            for em in emitters:
                val, ds = connect_light(scene, si, em, sigma_t, hit)
                f = bsdf.eval(bsdf_ctx, si, si.to_local(ds.d), hit)
                L += dr.select(hit, beta_hit * f * val * w_hit, 0.0)
            hw_s = [mi.Float(1.0) for _ in emitters]
            halo_s = mi.Bool(False)  # the surface's halo NEE was made (its continuation then takes hw_s)
            if has_medium and halo and self.surface_halo:
                # the lights' halos seen from the surface (the water glowing around a strobe, seen
                # from the chart: light scattered once near the strobe), by next-event estimation as
                # at water vertices, for every path whose segment ends here (weight β T(t_s), like the
                # direct light); the continuation from the surface weighs them by hw_s.  Without it
                # they came only from the surface's light-directed continuations: a few paths with
                # the chart's full halo light, fireflies in the dark water beside an edge-lit chart.
                axes_s = [dr.normalize(light_pos[k] - si.p) for k in range(len(emitters))]
                halo_s = reflects(bsdf, bsdf_ctx, si, hit)
                hit_h = hit & (depth + 2 < max_depth) & halo_s
                em_s, axis_s, pos_s = pick_light(sampler, axes_s, hit_h)
                c_sh, _ = halo_nee(sampler, si.spawn_ray, lambda w: bsdf.eval_pdf(bsdf_ctx, si, si.to_local(w), hit_h),
                                axes_s, axis_s, pos_s, em_s, hit_h, 1.0 / len(emitters), c_v)
                L += dr.select(hit_h, beta_hit * c_sh * w_hit, 0.0)
            bs, bw = bsdf.sample(bsdf_ctx, si, sampler.next_1d(surf), sampler.next_2d(surf), surf)
            wo_s = si.to_world(bs.wo)
            pdf_s = bs.pdf
            if has_medium and self.cone > 0 and len(emitters) > 0:
                # the same defensive mixture as in the medium (rays from a surface passing a light)
                wo_s, pdf_s = self._directed(si.p, wo_s,
                                             lambda w: bsdf.eval_pdf(bsdf_ctx, si, si.to_local(w), surf)[1],
                                             light_pos, aureole, sampler, surf, c_v)
                f_s, _ = bsdf.eval_pdf(bsdf_ctx, si, si.to_local(wo_s), surf)
                bw = dr.select(pdf_s > 0, f_s / pdf_s, 0.0)
                if halo and self.surface_halo:
                    for k in range(len(emitters)):
                        hw_s[k] = dr.select(surf & (depth + 2 < max_depth) & halo_s,
                                            self.mis_weight(pdf_s, aureole.pdf(axes_s[k], wo_s) / len(emitters)),
                                            1.0)
            surf &= pdf_s > 0
            beta = dr.select(surf, beta * bw, beta)
            r_s = si.spawn_ray(wo_s)
            o_next = dr.select(surf, r_s.o, o_next)
            d_next = dr.select(surf, r_s.d, d_next)
            cont |= surf

            if has_medium:
                pw = pw_next
            clean &= ~surf  # the path has been reflected by a surface: no longer backscatter
            if has_medium:
                hw = [dr.select(med, hw_next[k], dr.select(surf, hw_s[k], 1.0)) for k in range(len(emitters))]
                qs = dr.select(med, qs_next, 0.0)
            else:
                qs = mi.Float(0.0)
            depth = dr.select(cont, depth + 1, depth)
            active &= cont
            return sampler, active, depth, o_next, d_next, beta, L, hero, pw, Lb, clean, hw, qs, Lc, nw

        if emitters or self.ambient is None:
            # the hero wavelength that drives distance sampling is drawn once per path
            hero = mi.UInt32(dr.minimum(sampler.next_1d(active) * 4.0, 3.0))
            state = (sampler, active, mi.UInt32(0), mi.Point3f(ray.o), mi.Vector3f(ray.d),
                     mi.Spectrum(1.0), mi.Spectrum(0.0), hero, mi.Spectrum(0.25), mi.Spectrum(0.0),
                     mi.Bool(True), [mi.Float(1.0) for _ in emitters], mi.Float(0.0), mi.Spectrum(0.0),
                     mi.UInt32(0))
            state = dr.while_loop(state, cond, body,
                                  labels=("sampler", "active", "depth", "o", "d", "beta", "L", "hero", "pw",
                                          "Lb", "clean", "hw", "qs", "Lc", "nw"),
                                  label="rigsim_vol")
            L, Lb, Lc = state[6], state[9], state[13]
        else:
            L, Lb, Lc = mi.Spectrum(0.0), mi.Spectrum(0.0), mi.Spectrum(0.0)
        if self.daylight is not None:
            La, Lab = self.daylight.sample_ambient(scene, sampler, ray, medium, active)
            L, Lb = L + La, Lb + Lab
        aovs = [Lb[0], Lb[1], Lb[2], Lb[3]] if self.backscatter_aov else []
        if self.class_cos is not None:
            aovs += [Lc[0], Lc[1], Lc[2], Lc[3]]
        return L, mi.Bool(True), aovs

    # -- daylight ---------------------------------------------------------------------------

    def aov_names(self):
        """``backscatter.0..3`` (the path's four wavelengths) when ``backscatter_aov`` is on, then
        ``class_a.0..3`` when ``class_split_deg`` is given."""
        names = [f"backscatter.{j}" for j in range(4)] if self.backscatter_aov else []
        return names + ([f"class_a.{j}" for j in range(4)] if self.class_cos is not None else [])

    def to_string(self):
        return (f"RigsimVolIntegrator[max_depth={self.max_depth}, rr_depth={self.rr_depth}, mis={self.mis}, "
                f"equiangular={self.equiangular}]")


def sampling_defaults() -> dict:
    """How a render of ``rigsim_vol`` with no options draws its samples (:meth:`RigsimVolIntegrator.sampling` of a
    default one): two renders of one scene and seed are the same image only if these are."""
    return RigsimVolIntegrator().sampling()
