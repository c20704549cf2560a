"""Discrete particles in the water (marine snow): number, sizes, reflectance and how they scatter.

The continuum IOPs of :mod:`rigsim.water.model` describe light scattered by molecules and by
particles far below a pixel; what an underwater photographer calls *backscatter* is, besides that
veil, the bright specks and out-of-focus discs of discrete particles of 0.1 mm to a few mm
(marine-snow aggregates, detritus, zooplankton, resuspended sediment) in the strobe-lit water in
front of the port.  A :class:`ParticleField` describes them statistically; the scene places them
(:mod:`rigsim.scene.particles`, a seeded Poisson process) and both engines draw them as objects.

Model
-----
* **Number and sizes** — ``number_per_m3`` particles per m³ with diameters between ``d_min_mm`` and
  ``d_max_mm`` distributed as a power law ``n(d) ∝ d^−k`` (number per unit diameter), the form
  particle-imaging surveys report (slopes k ≈ 2.5–4.5; Jackson et al. 1997, Stemmann & Boss 2012).
* **Shape and scattering** — a diffuse (Lambertian) sphere of diameter d and reflectance ρ(λ)
  (:func:`lambert_sphere_phase`, Russell 1916): of the light falling on its geometric cross-section
  ``π d²/4`` the fraction ρ is reflected, strongly backwards (5/6 of it by more than 90°), the rest
  is absorbed.  Real aggregates are porous and scatter more forwards than a diffuse sphere; what a
  strobe-lit photograph shows of them is the light sent back towards the camera, which this model
  sets by ρ (see the named levels' sources, ``data/water/particle_levels.csv``).  The diffraction
  that doubles a large particle's extinction (extinction efficiency 2, van de Hulst 1957) goes into
  a lobe of ~λ/d ≈ 0.5 mrad about the forward direction — below a pixel — and is not modelled.
* **Relation to the continuum IOPs** — the field is *not* part of the water's a, b and c: the
  renderers place the particles as objects, which block, reflect and absorb light themselves.  Its
  own contribution, ``c_p = N ⟨π d²/4⟩``, ``b_p = ρ c_p``, ``a_p = (1 − ρ) c_p``, ``b_bp = 5/6 b_p``,
  is stated beside the water's (``rigsim water show``) so it is never counted twice: a water whose
  IOPs were measured in situ already holds the *average* effect of its particles, and a particle
  level added to it should be read as the specks of that water, not as more turbidity (the named
  levels' ``c_p`` is 0.001 1/m in clear ocean and 0.006 1/m in coastal water, well below those
  waters' b, but 0.5 and 0.8 1/m in a plankton bloom and in silt stirred up near the bottom,
  where the particles *are* a large part of the turbidity: :mod:`rigsim.scene.particles` places
  them only where they show one by one, and the report states how many were placed).

References
----------
Russell, H. N. (1916). On the albedo of the planets and their satellites. *Astrophys. J.* 43, 173.
van de Hulst, H. C. (1957). *Light Scattering by Small Particles*, Wiley (extinction paradox).
Jackson, G. A. et al. (1997). Particle size spectra between 1 µm and 1 cm at Monterey Bay.
*Deep-Sea Res. I* 44, 1739.  Stemmann, L. & Boss, E. (2012). Plankton and particle size and
packaging. *Annu. Rev. Mar. Sci.* 4, 263.  Alldredge, A. L. & Silver, M. W. (1988). Characteristics,
dynamics and significance of marine snow. *Prog. Oceanogr.* 20, 41.
"""

from __future__ import annotations

import functools
from typing import Annotated

import numpy as np
from pydantic import Field, model_validator

from rigsim.errors import ConfigError
from rigsim.schema import Real, Unit, float_table, frozen_type, invalid

__all__ = ["ParticleField", "particle_level", "particle_level_names", "lambert_sphere_phase",
           "lambert_sphere_intensity", "power_law_diameters_mm", "power_law_moment_mm",
           "LAMBERT_SPHERE_BACKSCATTER_FRACTION", "PARTICLE_LEVELS_TABLE"]

#: The named particle levels (data file with its sources), relative to ``data/``.
PARTICLE_LEVELS_TABLE = "water/particle_levels.csv"
#: Fraction of the light a diffuse sphere reflects that goes by more than 90° (into the hemisphere
#: the light came from): ``2π ∫_{θ>π/2} p(θ) sin θ dθ = 5/6`` for :func:`lambert_sphere_phase`.
LAMBERT_SPHERE_BACKSCATTER_FRACTION = 5.0 / 6.0


def lambert_sphere_phase(cos_scatter) -> np.ndarray:
    """Phase function of a diffuse (Lambertian) sphere, 1/sr, normalised over 4π.

    ``p(θ) = 2 / (3π²) · (sin α + (π − α) cos α)`` with the phase angle ``α = π − θ`` (θ the
    scattering angle: 0 forwards, π straight back to the light).  Russell (1916).

    Parameters
    ----------
    cos_scatter
        Cosine of the scattering angle θ (−1 … 1).

    Examples
    --------
    >>> bool(abs(lambert_sphere_phase(-1.0) - 2 / (3 * np.pi)) < 1e-12)   # straight back: (2/3π²)·π
    True
    >>> abs(float(lambert_sphere_phase(1.0))) < 1e-15                   # straight on: the lit side is hidden
    True
    """
    ct = np.clip(np.asarray(cos_scatter, float), -1.0, 1.0)
    alpha = np.pi - np.arccos(ct)  # phase angle
    return 2.0 / (3.0 * np.pi ** 2) * (np.sin(alpha) + (np.pi - alpha) * np.cos(alpha))


def lambert_sphere_intensity(irradiance, diameter_m, reflectance, cos_scatter) -> np.ndarray:
    """Radiant intensity (W/sr, or J/sr per flash) a diffuse sphere sends at scattering angle θ.

    ``I = E · π d²/4 · ρ · p(θ)``: the irradiance E on the beam's cross-section (W/m²) times the
    sphere's geometric cross-section, its reflectance and :func:`lambert_sphere_phase`.  Broadcasts.
    """
    d = np.asarray(diameter_m, float)
    return (np.asarray(irradiance, float) * (np.pi / 4.0) * d * d * np.asarray(reflectance, float)
            * lambert_sphere_phase(cos_scatter))


def power_law_moment_mm(p: float, d_min_mm: float, d_max_mm: float, slope: float) -> float:
    """``E[d^p]`` (mm^p) of diameters distributed as ``n(d) ∝ d^−slope`` on ``[d_min, d_max]``."""

    def integral(q):  # ∫ d^(q) dd over [d_min, d_max]
        if abs(q + 1.0) < 1e-12:
            return np.log(d_max_mm / d_min_mm)
        return (d_max_mm ** (q + 1.0) - d_min_mm ** (q + 1.0)) / (q + 1.0)

    return float(integral(p - slope) / integral(-slope))


def power_law_diameters_mm(u, d_min_mm: float, d_max_mm: float, slope: float) -> np.ndarray:
    """Diameters (mm) of ``n(d) ∝ d^−slope`` on ``[d_min, d_max]`` by inversion of its CDF at ``u`` ∈ [0, 1)."""
    u = np.asarray(u, float)
    if abs(slope - 1.0) < 1e-12:
        return d_min_mm * (d_max_mm / d_min_mm) ** u
    e = 1.0 - slope
    lo, hi = d_min_mm ** e, d_max_mm ** e
    return (lo + u * (hi - lo)) ** (1.0 / e)


_Mm = Annotated[Real, Field(gt=0, le=100), Unit("mm")]


@frozen_type
class ParticleField:
    """Discrete particles of a water (see the module docstring).

    Attributes
    ----------
    number_per_m3
        Particles with diameters in ``[d_min_mm, d_max_mm]`` per m³ (0 … 10⁷).
    d_min_mm, d_max_mm
        Smallest and largest diameter (mm, 0 < d_min < d_max <= 100).
    size_slope
        k of the number size distribution ``n(d) ∝ d^−k`` (0 … 8).
    albedo
        Diffuse reflectance ρ of a particle, the same at all wavelengths (0 … 1), unless
        ``reflectance`` gives a spectrum.
    reflectance_wavelength_nm, reflectance
        Optional reflectance spectrum (nm, strictly increasing; values 0 … 1, one per wavelength).
    level
        The named level it came from (``""``: given by numbers).
    source
        Where the numbers come from (for reports).
    """

    number_per_m3: Annotated[Real, Field(ge=0, le=1e7), Unit("1/m³")]
    d_min_mm: _Mm = 0.5
    d_max_mm: _Mm = 5.0
    size_slope: Annotated[Real, Field(ge=0, le=8)] = 3.0
    albedo: Annotated[Real, Field(ge=0, le=1)] = 0.5
    reflectance_wavelength_nm: float_table(increasing=True, unit="nm") = ()
    reflectance: float_table(nonnegative=True) = ()
    level: str = ""
    source: str = ""

    @model_validator(mode="after")
    def _check(self) -> "ParticleField":
        if not self.d_max_mm > self.d_min_mm:
            raise invalid(f"must be larger than d_min_mm ({self.d_min_mm:g}), got {self.d_max_mm:g}",
                          field="d_max_mm", allowed=f"> d_min_mm and <= 100 mm")
        if len(self.reflectance) != len(self.reflectance_wavelength_nm):
            raise invalid(f"has {len(self.reflectance)} values for {len(self.reflectance_wavelength_nm)} wavelengths",
                          field="reflectance", allowed="one value per entry of reflectance_wavelength_nm")
        if any(r > 1.0 for r in self.reflectance):
            raise invalid(f"must be <= 1, got {max(self.reflectance):g}", field="reflectance", allowed="0 … 1")
        return self

    # --- per particle ---------------------------------------------------------------------------
    def reflectance_at(self, wavelength_nm) -> np.ndarray:
        """ρ(λ) (0 … 1) at wavelengths (nm): the spectrum if given (held constant beyond it), else the albedo."""
        wl = np.asarray(wavelength_nm, float)
        if len(self.reflectance):
            return np.interp(wl, self.reflectance_wavelength_nm, self.reflectance)
        return np.full(wl.shape, float(self.albedo))

    def diameters_mm(self, u) -> np.ndarray:
        """Diameters (mm) for uniform numbers ``u`` ∈ [0, 1) (:func:`power_law_diameters_mm`)."""
        return power_law_diameters_mm(u, self.d_min_mm, self.d_max_mm, self.size_slope)

    @functools.cached_property
    def mean_diameter_mm(self) -> float:
        """⟨d⟩ (mm)."""
        return power_law_moment_mm(1.0, self.d_min_mm, self.d_max_mm, self.size_slope)

    @functools.cached_property
    def mean_cross_section_m2(self) -> float:
        """⟨π d²/4⟩, the mean geometric cross-section (m²)."""
        return float(np.pi / 4.0 * power_law_moment_mm(2.0, self.d_min_mm, self.d_max_mm, self.size_slope) * 1e-6)

    # --- as IOPs (not part of the water's a, b, c: see the module docstring) ----------------------
    def c_per_m(self) -> float:
        """Geometric extinction ``N ⟨π d²/4⟩`` (1/m)."""
        return float(self.number_per_m3) * self.mean_cross_section_m2

    def b_per_m(self, wavelength_nm) -> np.ndarray:
        """Light reflected by the particles, ``ρ(λ) c_p`` (1/m)."""
        return self.reflectance_at(wavelength_nm) * self.c_per_m()

    def a_per_m(self, wavelength_nm) -> np.ndarray:
        """Light absorbed by the particles, ``(1 − ρ(λ)) c_p`` (1/m)."""
        return (1.0 - self.reflectance_at(wavelength_nm)) * self.c_per_m()

    def bb_per_m(self, wavelength_nm) -> np.ndarray:
        """Backscattering ``5/6 · b_p`` (1/m; :data:`LAMBERT_SPHERE_BACKSCATTER_FRACTION`)."""
        return LAMBERT_SPHERE_BACKSCATTER_FRACTION * self.b_per_m(wavelength_nm)

    def describe(self) -> dict:
        """JSON-serialisable summary (for reports and image provenance)."""
        d = {"number_per_m3": self.number_per_m3, "d_min_mm": self.d_min_mm, "d_max_mm": self.d_max_mm,
             "size_slope": self.size_slope, "albedo": self.albedo, "level": self.level, "source": self.source,
             "mean_diameter_mm": self.mean_diameter_mm, "c_per_m": self.c_per_m()}
        if len(self.reflectance):
            d["reflectance_wavelength_nm"] = list(self.reflectance_wavelength_nm)
            d["reflectance"] = list(self.reflectance)
        return d


@functools.lru_cache(maxsize=1)
def _levels() -> dict[str, ParticleField]:
    from rigsim.data import load_table

    t = load_table(PARTICLE_LEVELS_TABLE)
    out = {}
    for i, name in enumerate(t["name"]):
        out[str(name)] = ParticleField(
            number_per_m3=float(t["number_per_m3"][i]), d_min_mm=float(t["d_min_mm"][i]),
            d_max_mm=float(t["d_max_mm"][i]), size_slope=float(t["size_slope"][i]), albedo=float(t["albedo"][i]),
            level=str(name), source=f"{PARTICLE_LEVELS_TABLE}: {t['basis'][i]}")
    return out


def particle_level_names() -> tuple[str, ...]:
    """Names of the particle levels in :data:`PARTICLE_LEVELS_TABLE`."""
    return tuple(_levels())


def particle_level(name: str) -> ParticleField:
    """The named particle level (``clear-ocean``, ``coastal``, ``plankton-bloom``, ``silt-near-bottom``).

    Raises
    ------
    ConfigError
        An unknown name (the message lists the known ones).
    """
    levels = _levels()
    if name not in levels:
        raise ConfigError(f"unknown particle level {name!r}", field="particles.level",
                          allowed=", ".join(levels))
    return levels[name]
