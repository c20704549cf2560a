"""Water descriptions: a preset name, constituents, or explicit IOPs (TOML).

A water TOML file has one ``[water]`` table, either by constituents::

    [water]
    name = "my bay"
    preset = "coastal"            # optional: start from a preset, override below
    chl_mg_per_m3 = 2.0           # alias chlorophyllConc
    cdom_a440_per_m = 0.2         # alias domConc
    small_particles_ppm = 0.1     # alias smallPartConc
    large_particles_ppm = 0.3     # alias largePartConc
    pure_water = "pope-fry-1997"  # smith-baker-1981 (default) | pope-fry-1997 | buiteveld-1994
    detritus_exponent = 0.724     # 0.702 write-up (default) | 0.724 original code
    phytoplankton = true          # add the original code's a_ph(440) = 0.0378 chl^0.627

or by explicit inherent optical properties::

    [water]
    a_per_m = 0.1                 # a number (all wavelengths) or a CSV of wavelength_nm,value
    b_per_m = "b.csv"
    phase = "ff:0.0183"           # kopelevich | petzold-average | rayleigh | hg:G | ff:BB | a CSV of angle_deg,value
    wavelength_nm = 532           # optional: pose the problem at these wavelengths only

Relative CSV paths resolve against the TOML file's folder.

Either kind may add discrete particles (marine snow, :mod:`rigsim.water.particles`): a named level,
numbers, or a level with some numbers changed::

    [water.particles]
    level = "coastal"             # clear-ocean | coastal | plankton-bloom | silt-near-bottom
    number_per_m3 = 5e4           # particles between d_min_mm and d_max_mm per m³
    d_min_mm = 0.25
    d_max_mm = 5.0
    size_slope = 3.0              # n(d) ∝ d^-size_slope
    albedo = 0.03                 # diffuse reflectance of a particle

The schema is :class:`WaterFile` / :class:`WaterTable` (pydantic, read by
:func:`rigsim.schema.read_toml` like every config file); preset names and
command-line overrides go through the same table model, so ``--chl -2`` and
``chl_mg_per_m3 = -2`` give the same message.  The water classes themselves
(:class:`~rigsim.water.model.ConstituentWater`, :class:`~rigsim.water.model.TabulatedWater`)
check their values when built.
"""

from __future__ import annotations

import dataclasses
import math
import numbers
import os
from pathlib import Path
from typing import Annotated, Any, ClassVar

import numpy as np
from pydantic import BeforeValidator, Field, model_validator

from rigsim.schema import Bool, FileModel, Real, invalid, read_toml, validate
from rigsim.data import read_csv_table
from rigsim.errors import ConfigError, RigsimError
from rigsim.water.model import ConstituentWater, Spectrum1D, TabulatedWater, Water, with_particles
from rigsim.water.particles import ParticleField, particle_level, particle_level_names
from rigsim.water.phase import (
    FournierForand,
    HenyeyGreenstein,
    MixturePhase,
    PhaseFunction,
    RayleighWater,
    kopelevich_large_particle,
    kopelevich_small_particle,
    petzold_average_particle,
    tabulated_from_csv,
)
from rigsim.water.presets import preset
from rigsim.water.scattering import scattering_pure_water

__all__ = ["load_water", "water_from_table", "phase_from_spec", "WaterFile", "WaterTable", "ParticlesTable",
           "CONSTITUENT_ALIASES", "PHASE_SPECS"]

#: Canonical constituent keys and the original code's names accepted as aliases.
CONSTITUENT_ALIASES = {
    "chlorophyllConc": "chl_mg_per_m3",
    "domConc": "cdom_a440_per_m",
    "smallPartConc": "small_particles_ppm",
    "largePartConc": "large_particles_ppm",
}
_CONSTITUENT_KEYS = ("chl_mg_per_m3", "cdom_a440_per_m", "small_particles_ppm", "large_particles_ppm")
_MODEL_KEYS = ("pure_water", "detritus_exponent", "phytoplankton", "pure_water_scattering")
_IOP_KEYS = ("a_per_m", "b_per_m", "phase", "wavelength_nm")


def _iop_value(v: Any) -> float | str:
    """``a_per_m``/``b_per_m``: a number >= 0 (1/m, all wavelengths) or a CSV file name."""
    if isinstance(v, str):
        return v
    if isinstance(v, bool) or not isinstance(v, numbers.Real):
        raise invalid(f"must be a number or a CSV file name, got {v!r}",
                      allowed=">= 0 1/m, or a CSV of wavelength_nm,value")
    if not math.isfinite(v):
        raise invalid(f"must be finite, got {v!r}", allowed=">= 0 1/m")
    if v < 0:
        raise invalid(f"must be >= 0, got {v!r}", allowed=">= 0 1/m")
    return float(v)


def _wavelengths(v: Any) -> tuple[float, ...]:
    """``wavelength_nm``: a positive number or a non-empty list of them."""
    items = v if isinstance(v, list) else [v]
    if not items or not all(isinstance(x, numbers.Real) and not isinstance(x, bool) and math.isfinite(x) and x > 0
                            for x in items):
        raise invalid(f"must be a positive number or a list of them, got {v!r}", allowed="nm > 0")
    return tuple(float(x) for x in items)


_Concentration = Annotated[Real, Field(ge=0)]


class ParticlesTable(FileModel):
    """The ``[water.particles]`` table: a named level and/or the fields of
    :class:`~rigsim.water.particles.ParticleField` (numbers given override the level's)."""

    level: str | None = None
    number_per_m3: Real | None = None
    d_min_mm: Real | None = None
    d_max_mm: Real | None = None
    size_slope: Real | None = None
    albedo: Real | None = None

    def field(self, *, file=None) -> ParticleField:
        """The particle field it describes (ConfigError naming ``water.particles.<key>``)."""
        given = {k: getattr(self, k) for k in ("number_per_m3", "d_min_mm", "d_max_mm", "size_slope", "albedo")
                 if getattr(self, k) is not None}
        try:
            if self.level is not None:
                base = particle_level(self.level)
                return dataclasses.replace(base, **given, source=base.source if not given else
                                           f"{base.source}; changed: {', '.join(sorted(given))}")
            if "number_per_m3" not in given:
                raise ConfigError("missing: give number_per_m3 or a level", field="number_per_m3",
                                  allowed="a number >= 0 per m³, or level = " + " | ".join(particle_level_names()))
            return ParticleField(**given, source=str(file or "inline"))
        except ConfigError as exc:
            fld = (exc.field or "").split(".")[-1]
            raise ConfigError(exc.message, file=file, field=f"water.particles.{fld}".rstrip("."),
                              allowed=exc.allowed) from None


class WaterTable(FileModel):
    """The ``[water]`` table: a preset and/or constituents, or explicit IOPs (see the module docstring).

    The original code's names (:data:`CONSTITUENT_ALIASES`) are accepted for the
    constituents and reported under their canonical names.
    """

    KEY_ALIASES: ClassVar[dict[str, str]] = CONSTITUENT_ALIASES

    name: str | None = None
    preset: str | None = None
    chl_mg_per_m3: _Concentration | None = None
    cdom_a440_per_m: _Concentration | None = None
    small_particles_ppm: _Concentration | None = None
    large_particles_ppm: _Concentration | None = None
    pure_water: str | None = None
    pure_water_scattering: str | None = None
    detritus_exponent: Annotated[Real, Field(ge=0, le=2.0)] | None = None
    phytoplankton: Bool | None = None
    a_per_m: Annotated[float | str, BeforeValidator(_iop_value)] | None = None
    b_per_m: Annotated[float | str, BeforeValidator(_iop_value)] | None = None
    phase: str | None = None
    wavelength_nm: Annotated[tuple[float, ...], BeforeValidator(_wavelengths)] | None = None
    particles: ParticlesTable | None = None

    @model_validator(mode="before")
    @classmethod
    def _aliases(cls, data: Any) -> Any:
        if not isinstance(data, dict):
            return data
        out: dict[str, Any] = {}
        for k, v in data.items():
            key = CONSTITUENT_ALIASES.get(k, k)
            if key in out:
                raise invalid(f"{key} is given twice (also as {k!r})", field=key,
                              allowed=f"one of {key}, {k}")
            out[key] = v
        return out

    @model_validator(mode="after")
    def _check(self) -> "WaterTable":
        iop = [k for k in _IOP_KEYS if getattr(self, k) is not None]
        cons = [k for k in _CONSTITUENT_KEYS + _MODEL_KEYS + ("preset",) if getattr(self, k) is not None]
        if iop and cons:
            raise invalid(f"mixes explicit IOPs ({', '.join(iop)}) with constituents ({', '.join(cons)})",
                          allowed="either constituents or a_per_m/b_per_m/phase")
        if iop:
            for k in ("a_per_m", "b_per_m"):
                if getattr(self, k) is None:
                    raise invalid("missing (explicit-IOP water needs a_per_m and b_per_m)", field=k)
        return self

    @property
    def explicit_iops(self) -> bool:
        """True for a water given by a(λ), b(λ) and a phase function."""
        return self.a_per_m is not None

    def constituent_options(self) -> dict[str, Any]:
        """Constituent concentrations and model options given (for :class:`ConstituentWater`)."""
        return {k: getattr(self, k) for k in _CONSTITUENT_KEYS + _MODEL_KEYS if getattr(self, k) is not None}


class WaterFile(FileModel):
    """A water file: one ``[water]`` table."""

    water: WaterTable


#: The phase-function names accepted in ``phase = ...`` (besides a CSV file).
PHASE_SPECS = ("kopelevich", "kopelevich:NS:NL", "petzold-average", "rayleigh", "hg:G", "ff:BB")


def _kopelevich_for_iop(b: Spectrum1D, small_ppm: float, large_ppm: float) -> MixturePhase:
    """Kopelevich mixture for a water whose b(λ) is given: the pure-water share is
    b_w(λ)/b(λ); the rest is split between small and large particles in the ratio of
    their scattering for the given volume concentrations."""
    s, l = kopelevich_small_particle(), kopelevich_large_particle()

    def weights(wl):
        bw = scattering_pure_water(wl)
        btot = np.maximum(b(wl), bw)
        bs = small_ppm * s.norm * (550.0 / wl) ** 1.7
        bl = large_ppm * l.norm * (550.0 / wl) ** 0.3
        part = 1.0 - bw / btot
        tot = bs + bl
        return np.stack([bw / btot, part * bs / tot, part * bl / tot], axis=-1)

    return MixturePhase([RayleighWater(), s, l], weights, name="kopelevich")


def phase_from_spec(spec: str, *, b: Spectrum1D, file=None, base_dir: Path | None = None) -> PhaseFunction:
    """A phase function from its name in a water file (see :data:`PHASE_SPECS`)."""
    field = "water.phase"
    if not isinstance(spec, str) or not spec:
        raise ConfigError(f"must be a string, got {spec!r}", file=file, field=field, allowed=", ".join(PHASE_SPECS))
    low = spec.lower()
    try:
        if low == "kopelevich":
            return _kopelevich_for_iop(b, 1.0, 1.0)
        if low.startswith("kopelevich:"):
            _, ns, nl = low.split(":")
            ns_v, nl_v = float(ns), float(nl)
            if ns_v < 0 or nl_v < 0 or ns_v + nl_v <= 0:
                raise ValueError
            return _kopelevich_for_iop(b, ns_v, nl_v)
        if low in ("petzold-average", "petzold"):
            return petzold_average_particle()
        if low == "rayleigh":
            return RayleighWater()
        if low.startswith("hg:"):
            return HenyeyGreenstein(float(low[3:]))
        if low.startswith("ff:"):
            return FournierForand.from_backscatter_fraction(float(low[3:]))
    except ConfigError as exc:
        raise ConfigError(exc.message, file=file, field=field, allowed=exc.allowed) from None
    except ValueError:
        raise ConfigError(f"cannot read phase {spec!r}", file=file, field=field,
                          allowed=", ".join(PHASE_SPECS) + ", or a CSV of angle_deg,value") from None
    path = Path(spec)
    if base_dir is not None and not path.is_absolute():
        path = base_dir / path
    if path.suffix.lower() == ".csv" or os.path.exists(path):
        if not os.path.isfile(path):
            raise ConfigError(f"phase table {path} not found", file=file, field=field)
        return tabulated_from_csv(path)
    raise ConfigError(f"unknown phase function {spec!r}", file=file, field=field,
                      allowed=", ".join(PHASE_SPECS) + ", or a CSV of angle_deg,value")


def _spectrum_value(v: float | str, key: str, *, file, base_dir: Path | None) -> Spectrum1D:
    """a(λ) or b(λ) (1/m) from a validated value: a constant, or a CSV of wavelength_nm,value."""
    field = f"water.{key}"
    if not isinstance(v, str):
        return Spectrum1D.constant(float(v), label=field)
    path = Path(v)
    if base_dir is not None and not path.is_absolute():
        path = base_dir / path
    if not os.path.isfile(path):
        raise ConfigError(f"CSV file {path} not found", file=file, field=field)
    try:
        t = read_csv_table(path)
    except RigsimError as exc:
        raise ConfigError(str(exc), file=file, field=field) from None
    names = list(t.columns)
    if len(names) < 2 or names[0] != "wavelength_nm":
        raise ConfigError(f"{path} needs columns wavelength_nm,value", file=file, field=field)
    wl, vals = t[names[0]], t[names[1]]
    if wl.dtype.kind != "f" or vals.dtype.kind != "f" or np.any(np.diff(wl) <= 0):
        raise ConfigError(f"{path}: wavelengths must be increasing numbers", file=file, field=field)
    if np.any(~np.isfinite(vals)) or np.any(vals < 0):
        raise ConfigError(f"{path}: values must be finite and >= 0", file=file, field=field, allowed=">= 0 1/m")
    return Spectrum1D(values=vals, wavelength_nm=wl, label=f"{path} ({key})")


def _to_water(t: WaterTable, *, file, base_dir: Path | None) -> Water:
    """The :class:`Water` of a validated table (CSV tables, phase functions and presets read here)."""
    w = _continuum(t, file=file, base_dir=base_dir)
    if t.particles is not None:
        w = with_particles(w, t.particles.field(file=file))
    return w


def _continuum(t: WaterTable, *, file, base_dir: Path | None) -> Water:
    """The water's IOPs (everything but the particles)."""
    name = t.name if t.name is not None else (Path(file).stem if file else "custom")
    if t.explicit_iops:
        a = _spectrum_value(t.a_per_m, "a_per_m", file=file, base_dir=base_dir)
        b = _spectrum_value(t.b_per_m, "b_per_m", file=file, base_dir=base_dir)
        phase = phase_from_spec(t.phase if t.phase is not None else "petzold-average", b=b, file=file,
                                base_dir=base_dir)
        wl = None
        if t.wavelength_nm is not None:
            wl = np.array(t.wavelength_nm, float)
            for spec in (a, b):
                lo, hi = spec.range_nm
                if wl.min() < lo or wl.max() > hi:
                    raise ConfigError(f"{spec.label} covers {lo:g}–{hi:g} nm, not {wl.tolist()}",
                                      file=file, field="water.wavelength_nm", allowed=f"{lo:g}–{hi:g} nm")
        return TabulatedWater(str(name), a, b, phase, source=str(file or "inline"), wavelength_nm=wl)
    params = t.constituent_options()
    try:
        if t.preset is not None:
            w = preset(t.preset, **params)
            if isinstance(w, ConstituentWater) and t.name is not None:
                w = dataclasses.replace(w, name=str(name))
            return w
        return ConstituentWater(name=str(name), **params)
    except ConfigError as exc:
        fld = exc.field or ""
        fld = "water.preset" if fld == "water" and file is not None else fld
        fld = fld if fld.startswith("water") else f"water.{fld}".rstrip(".")
        raise ConfigError(exc.message, file=file, field=fld, allowed=exc.allowed) from None


def water_from_table(table: dict, *, file=None, base_dir: Path | None = None) -> Water:
    """Build a Water from a parsed ``[water]`` table (see the module docstring).

    Parameters
    ----------
    table
        The table's keys and values (canonical names or the original code's aliases).
    file
        The file it came from, for messages.
    base_dir
        Folder that relative CSV paths resolve against.

    Raises
    ------
    ConfigError
        One line naming ``water.<key>``: unknown key, wrong type, out of range,
        constituents mixed with IOPs, unknown preset or phase function, missing CSV.
    """
    return _to_water(validate(WaterTable, table, file=file, prefix="water"), file=file, base_dir=base_dir)


def load_water(spec: str | Path, *, particles: str | ParticleField | None = None, **overrides: float | None) -> Water:
    """A water from a preset name or a TOML file, with optional constituent overrides.

    Parameters
    ----------
    spec
        A preset name (``coastal``, ``jerlov-II`` …) or a path to a water TOML file.
    particles
        Discrete particles to give the water (replacing its own, if any): a level name
        (:func:`~rigsim.water.particles.particle_level_names`), a ParticleField, ``"none"`` for
        none, or None (keep the water's).
    overrides
        ``chl_mg_per_m3`` (mg/m³), ``cdom_a440_per_m`` (1/m), ``small_particles_ppm``,
        ``large_particles_ppm`` (ppm by volume); None: keep — only for constituent waters.

    Raises
    ------
    ConfigError
        One line naming the file (if any), the field and what is allowed.
    """
    w = _load_water(spec, **overrides)
    if particles is None:
        return w
    if isinstance(particles, str):
        if particles.lower() == "none":
            return with_particles(w, None)
        try:
            particles = particle_level(particles)
        except ConfigError as exc:
            raise ConfigError(exc.message, field="particles", allowed=exc.allowed + ", none") from None
    return with_particles(w, particles)


def _load_water(spec: str | Path, **overrides: float | None) -> Water:
    overrides = {k: v for k, v in overrides.items() if v is not None}
    for k in overrides:
        if k not in _CONSTITUENT_KEYS:
            raise ConfigError(f"unknown override {k!r}", allowed=", ".join(_CONSTITUENT_KEYS))
    s = str(spec)
    path = Path(s)
    if s.endswith(".toml") or os.path.isfile(path):
        doc = read_toml(path)
        table = doc.get("water")
        if overrides and isinstance(table, dict):
            if any(k in table for k in _IOP_KEYS):
                raise ConfigError("constituent overrides do not apply to an explicit-IOP water", file=path,
                                  field="water")
            table = {k: v for k, v in table.items() if CONSTITUENT_ALIASES.get(k) not in overrides}
            doc = {**doc, "water": {**table, **overrides}}
        return _to_water(validate(WaterFile, doc, file=path).water, file=path, base_dir=path.parent)
    if s.lower().startswith("jerlov") and overrides:
        raise ConfigError("constituent overrides apply only to constituent presets, not Jerlov types",
                          field="water")
    return water_from_table({"preset": s, **overrides})
