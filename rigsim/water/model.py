"""Water bodies: inherent optical properties (IOPs) as functions of wavelength.

A :class:`Water` gives, for wavelengths in nm: absorption ``a``, scattering ``b``,
backscattering ``b_b``, attenuation ``c = a + b`` (all 1/m), single-scattering
albedo ``b/c``, the (possibly wavelength-dependent) phase function and ``Kd``.
Two kinds exist:

* :class:`ConstituentWater` — built from chlorophyll, CDOM and particle
  concentrations (absorption by Bricaud et al., scattering by Kopelevich).
* :class:`TabulatedWater` — explicit IOPs: numbers or tables of a(λ), b(λ) and a
  named phase function (Jerlov types, user TOML files).
"""

from __future__ import annotations

import functools
from abc import ABC, abstractmethod
from dataclasses import dataclass, field

import numpy as np

from rigsim.errors import ConfigError, SpectrumRangeError
from rigsim.spectrum import as_wavelengths, interp_table
from rigsim.water import absorption as _abs
from rigsim.water import scattering as _sca
from rigsim.water.kd import kd as _kd
from rigsim.water.particles import ParticleField
from rigsim.water.phase import (
    MixturePhase,
    PhaseFunction,
    RayleighWater,
    kopelevich_large_particle,
    kopelevich_small_particle,
)

__all__ = ["Water", "ConstituentWater", "TabulatedWater", "Spectrum1D", "with_particles"]


class Water(ABC):
    """Inherent optical properties of a homogeneous water body.

    ``particles`` is its field of discrete particles (marine snow,
    :class:`~rigsim.water.particles.ParticleField`) or None; it is not part of the IOPs (see
    :mod:`rigsim.water.particles`).
    """

    name: str = "water"
    particles: "ParticleField | None" = None

    @abstractmethod
    def a_per_m(self, wavelength_nm) -> np.ndarray:
        """Absorption coefficient a(λ), 1/m."""

    @abstractmethod
    def b_per_m(self, wavelength_nm) -> np.ndarray:
        """Scattering coefficient b(λ), 1/m."""

    @property
    @abstractmethod
    def phase(self) -> PhaseFunction:
        """Normalised phase function β(ψ;λ)/b(λ)."""

    @property
    @abstractmethod
    def wavelength_range_nm(self) -> tuple[float, float]:
        """The wavelengths (nm) for which the IOPs are defined."""

    @abstractmethod
    def describe(self) -> dict:
        """JSON-serialisable description (inputs and model choices)."""

    # derived quantities -------------------------------------------------------------
    def c_per_m(self, wavelength_nm) -> np.ndarray:
        """Beam attenuation c = a + b, 1/m."""
        return self.a_per_m(wavelength_nm) + self.b_per_m(wavelength_nm)

    def bb_per_m(self, wavelength_nm) -> np.ndarray:
        """Backscattering coefficient b_b = b · (b_b/b), 1/m."""
        wl = as_wavelengths(wavelength_nm)
        return self.b_per_m(wl) * self.phase.backscatter_fraction(wl)

    def albedo(self, wavelength_nm) -> np.ndarray:
        """Single-scattering albedo b/c (0 where c = 0)."""
        b = self.b_per_m(wavelength_nm)
        c = self.c_per_m(wavelength_nm)
        return np.divide(b, c, out=np.zeros_like(b), where=c > 0)

    def kd_per_m(self, wavelength_nm, sun_zenith_deg: float = 0.0, method: str = "lee-2005") -> np.ndarray:
        """Diffuse attenuation of downwelling irradiance Kd(λ), 1/m (see :mod:`rigsim.water.kd`)."""
        wl = as_wavelengths(wavelength_nm)
        return _kd(self.a_per_m(wl), self.bb_per_m(wl), sun_zenith_deg, method)

    def iop_table(self, wavelength_nm) -> dict[str, np.ndarray]:
        """All IOPs at the given wavelengths (the ``rigsim water show`` table)."""
        wl = as_wavelengths(np.atleast_1d(wavelength_nm))
        a, b = self.a_per_m(wl), self.b_per_m(wl)
        bb = b * self.phase.backscatter_fraction(wl)
        c = a + b
        return {
            "wavelength_nm": wl,
            "a_per_m": a,
            "b_per_m": b,
            "c_per_m": c,
            "bb_per_m": bb,
            "albedo": np.divide(b, c, out=np.zeros_like(b), where=c > 0),
            "kd_per_m": self.kd_per_m(wl),
        }

    def check_range(self, wavelength_nm) -> np.ndarray:
        """Raise a clear error if the IOPs are not defined at ``wavelength_nm``."""
        wl = as_wavelengths(wavelength_nm)
        lo, hi = self.wavelength_range_nm
        if wl.size and (wl.min() < lo - 1e-9 or wl.max() > hi + 1e-9):
            raise SpectrumRangeError(
                f"water {self.name!r} is defined for {lo:g}–{hi:g} nm; asked for {wl.min():g}–{wl.max():g} nm",
                field="wavelength_nm", allowed=f"{lo:g}–{hi:g} nm")
        return wl

    def __repr__(self) -> str:
        return f"<{type(self).__name__} {self.name}>"


def _nonneg(value, field_name: str) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ConfigError(f"must be a number, got {value!r}", field=field_name, allowed=">= 0") from None
    if not np.isfinite(v) or v < 0:
        raise ConfigError(f"must be >= 0, got {value!r}", field=field_name, allowed=">= 0")
    return v


@dataclass(frozen=True, eq=True)
class ConstituentWater(Water):
    """Water from constituents (the original pbrt water volume's model).

    ``a = a_pw + 0.0124 chl^0.702 e^{−0.011(λ−440)} + a_y(440) e^{−0.014(λ−440)} [+ a_ph]``
    and Kopelevich scattering (see :mod:`rigsim.water.absorption`, :mod:`rigsim.water.scattering`).

    Parameters
    ----------
    chl_mg_per_m3
        Chlorophyll-a concentration, mg/m³ (>= 0).
    cdom_a440_per_m
        CDOM absorption at 440 nm, 1/m (>= 0).
    small_particles_ppm, large_particles_ppm
        Volume concentrations of Kopelevich small and large particles, ppm (>= 0).
    pure_water
        Pure-water absorption table (see :data:`~rigsim.water.absorption.PURE_WATER_ABSORPTION_METHODS`).
    detritus_exponent
        Exponent of chl in the detritus term: 0.702 (write-up, default) or 0.724 (original code).
    phytoplankton
        Add the original code's phytoplankton absorption a_ph(440) = 0.0378 chl^0.627.
    pure_water_scattering
        Pure-water scattering law (see :data:`~rigsim.water.scattering.PURE_WATER_SCATTERING_METHODS`).
    name
        Display name.
    """

    chl_mg_per_m3: float = 0.0
    cdom_a440_per_m: float = 0.0
    small_particles_ppm: float = 0.0
    large_particles_ppm: float = 0.0
    pure_water: str = "smith-baker-1981"
    detritus_exponent: float = _abs.DETRITUS_EXPONENT_WRITEUP
    phytoplankton: bool = False
    pure_water_scattering: str = "kopelevich-1983"
    name: str = field(default="custom", compare=False)
    particles: ParticleField | None = None

    def __post_init__(self):
        for f in ("chl_mg_per_m3", "cdom_a440_per_m", "small_particles_ppm", "large_particles_ppm"):
            object.__setattr__(self, f, _nonneg(getattr(self, f), f))
        _abs.absorption_pure_water(550.0, self.pure_water)  # validates the name
        _sca.scattering_pure_water(550.0, self.pure_water_scattering)

    @functools.cached_property
    def wavelength_range_nm(self) -> tuple[float, float]:
        lo, hi = _abs.pure_water_absorption_range_nm(self.pure_water)
        if self.phytoplankton:
            plo, phi = _abs.phytoplankton_absorption_range_nm()
            lo, hi = max(lo, plo), min(hi, phi)
        return lo, hi

    def a_per_m(self, wavelength_nm):
        wl = as_wavelengths(wavelength_nm)
        a = (_abs.absorption_pure_water(wl, self.pure_water)
             + _abs.absorption_detritus_Bricaud1998(wl, self.chl_mg_per_m3, exponent=self.detritus_exponent)
             + _abs.absorption_cdom_Bricaud1981(wl, self.cdom_a440_per_m))
        if self.phytoplankton:
            a = a + _abs.absorption_phytoplankton_Bricaud1995(wl, self.chl_mg_per_m3)
        return a

    def _b_components(self, wl) -> np.ndarray:
        wl = as_wavelengths(wl)
        return np.stack([
            _sca.scattering_pure_water(wl, self.pure_water_scattering),
            _sca.scattering_small_particles_Kopelevich1983(wl, self.small_particles_ppm),
            _sca.scattering_large_particles_Kopelevich1983(wl, self.large_particles_ppm),
        ], axis=-1)

    def b_per_m(self, wavelength_nm):
        return self._b_components(wavelength_nm).sum(axis=-1)

    @functools.cached_property
    def phase(self) -> MixturePhase:
        """Kopelevich mixture: weights ∝ each component's b_i(λ)."""
        def weights(wl):
            comps = self._b_components(wl)
            return comps / comps.sum(axis=-1, keepdims=True)

        return MixturePhase([RayleighWater(), kopelevich_small_particle(), kopelevich_large_particle()],
                            weights, name="kopelevich")

    def describe(self) -> dict:
        return {"kind": "constituents", "name": self.name,
                "chl_mg_per_m3": self.chl_mg_per_m3, "cdom_a440_per_m": self.cdom_a440_per_m,
                "small_particles_ppm": self.small_particles_ppm,
                "large_particles_ppm": self.large_particles_ppm,
                "pure_water": self.pure_water, "detritus_exponent": self.detritus_exponent,
                "phytoplankton": self.phytoplankton, "pure_water_scattering": self.pure_water_scattering,
                "phase": "kopelevich"}


@dataclass(frozen=True, eq=False)
class Spectrum1D:
    """A non-negative quantity of wavelength: a constant, or a table interpolated linearly.

    Attributes
    ----------
    wavelength_nm, values
        The table (nm, value); a constant has ``wavelength_nm is None`` and one value.
    label
        Name used in error messages (e.g. the file it came from).
    """

    values: np.ndarray
    wavelength_nm: np.ndarray | None = None
    label: str = "spectrum"

    @classmethod
    def constant(cls, value: float, label: str = "constant") -> "Spectrum1D":
        return cls(values=np.array([float(value)]), wavelength_nm=None, label=label)

    @property
    def range_nm(self) -> tuple[float, float]:
        if self.wavelength_nm is None:
            return (0.0, np.inf)
        return float(self.wavelength_nm[0]), float(self.wavelength_nm[-1])

    def __call__(self, wavelength_nm) -> np.ndarray:
        wl = as_wavelengths(wavelength_nm)
        if self.wavelength_nm is None:
            return np.full(wl.shape, float(self.values[0]))
        return interp_table(wl, self.wavelength_nm, self.values, name=self.label)


def with_particles(water: Water, particles: ParticleField | None) -> Water:
    """A copy of ``water`` with the particle field ``particles`` (None: without particles)."""
    import copy
    import dataclasses

    if water.particles == particles:
        return water  # the same object (a preset stays the cached preset)
    if dataclasses.is_dataclass(water):
        return dataclasses.replace(water, particles=particles)
    w = copy.copy(water)
    w.particles = particles
    return w


class TabulatedWater(Water):
    """Water given by explicit IOPs: a(λ), b(λ) and a phase function.

    Parameters
    ----------
    name
        Display name.
    a, b
        :class:`Spectrum1D` of absorption and scattering, 1/m.
    phase
        A :class:`~rigsim.water.phase.PhaseFunction` (may depend on wavelength).
    source
        Where the numbers come from (for reports).
    wavelength_nm
        Optional: the wavelengths at which the problem is posed (nm); other
        wavelengths are refused.
    """

    def __init__(self, name: str, a: Spectrum1D, b: Spectrum1D, phase: PhaseFunction, *,
                 source: str = "", wavelength_nm=None, extra: dict | None = None):
        self.name = name
        self._a, self._b, self._phase = a, b, phase
        self.source = source
        self.posed_wavelength_nm = None if wavelength_nm is None else np.atleast_1d(
            as_wavelengths(wavelength_nm))
        self.extra = extra or {}

    @property
    def phase(self) -> PhaseFunction:
        return self._phase

    @property
    def wavelength_range_nm(self) -> tuple[float, float]:
        la, ha = self._a.range_nm
        lb, hb = self._b.range_nm
        lo, hi = max(la, lb), min(ha, hb)
        if self.posed_wavelength_nm is not None:
            lo = max(lo, float(self.posed_wavelength_nm.min()))
            hi = min(hi, float(self.posed_wavelength_nm.max()))
        return lo, hi

    def _check_posed(self, wl):
        if self.posed_wavelength_nm is not None:
            ok = np.isclose(np.asarray(wl)[..., None], self.posed_wavelength_nm).any(axis=-1)
            if not np.all(ok):
                bad = np.asarray(wl)[~ok]
                raise SpectrumRangeError(
                    f"water {self.name!r} is posed only at {self.posed_wavelength_nm.tolist()} nm; "
                    f"asked for {bad.tolist()} nm", field="wavelength_nm",
                    allowed=", ".join(f"{w:g}" for w in self.posed_wavelength_nm))

    def a_per_m(self, wavelength_nm):
        wl = as_wavelengths(wavelength_nm)
        self._check_posed(wl)
        return self._a(wl)

    def b_per_m(self, wavelength_nm):
        wl = as_wavelengths(wavelength_nm)
        self._check_posed(wl)
        return self._b(wl)

    def describe(self) -> dict:
        d = {"kind": "iop", "name": self.name, "phase": self._phase.name, "source": self.source}
        if self._a.wavelength_nm is None:
            d["a_per_m"] = float(self._a.values[0])
        if self._b.wavelength_nm is None:
            d["b_per_m"] = float(self._b.values[0])
        if self.posed_wavelength_nm is not None:
            d["wavelength_nm"] = self.posed_wavelength_nm.tolist()
        d.update(self.extra)
        return d
