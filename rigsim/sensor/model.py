"""Typed description of a camera sensor and its TOML loader.

A sensor file (``sensors/*.toml``) describes one camera in EMVA 1288 terms:
spectral quantum efficiency per CFA channel, geometry, and the noise and gain
parameters of the linear camera model.  Unknown keys are errors naming the file
and key; every noise parameter must name its source (a public measurement) or
say ``assumption`` in the ``[sources]`` table.

File layout (all keys shown; ``ir_cut_file`` is optional)::

    [sensor]
    name = "Sony ILCE-7RM2"            # shown in reports
    cfa_pattern = "RGGB"               # RGGB, BGGR, GRBG or GBRG (top-left 2×2)
    pixel_pitch_um = 4.51
    resolution = [5304, 7952]          # rows, cols
    bit_depth = 14
    black_level_dn = 512

    [spectral]
    file = "sensors/camera_sony_ilce-7rm2.csv"   # wavelength_nm,red,green,blue (relative)
    peak_qe = 0.55                     # scalar, or [r, g, b] per channel
    ir_cut_file = "sensors/filter_....csv"       # optional: wavelength_nm,value

    [noise]
    full_well_e = 50400
    dark_current_e_per_s = 0.1         # at dark_current_ref_temp_c
    dark_current_ref_temp_c = 25.0
    dark_current_doubling_c = 6.3
    prnu_percent = 0.5                 # σ of the gain map, % of signal
    dsnu_e = 0.3                       # σ of the dark-offset map, e⁻

    [[iso]]                            # one table per analog gain step
    iso = 100
    gain_dn_per_e = 0.315              # conversion gain K
    read_noise_e = 4.49                # input-referred temporal dark noise σ_d

    [sources]                          # one entry per noise key (URL or "assumption: …")

Relative file names are looked up beside the TOML file first, then in the data
tree (:data:`rigsim.data.DATA_DIR`).
"""

from __future__ import annotations

import functools
import numbers
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import BeforeValidator, Field, model_validator

from rigsim.schema import FileModel, Int, Real, invalid, load_file
from rigsim.data import DATA_DIR, read_csv_table
from rigsim.errors import ConfigError, DataError, unknown_name_error
from rigsim.spectrum import interp_table

#: Folder of the shipped sensor files (``sensors/`` at the repository root).
SENSORS_DIR = Path(__file__).resolve().parents[2] / "sensors"

#: Keys of ``[noise]`` and ``[[iso]]`` that must be cited in ``[sources]``.
NOISE_KEYS = ("full_well_e", "dark_current_e_per_s", "dark_current_doubling_c",
              "prnu_percent", "dsnu_e", "gain_dn_per_e", "read_noise_e", "peak_qe")

CFA_PATTERNS = ("RGGB", "BGGR", "GRBG", "GBRG")


# ---------------------------------------------------------------- file schema (pydantic)
_SOURCE_EXTRA = ("spectral", "resolution", "pixel_pitch_um", "black_level_dn", "bit_depth", "ir_cut")


def _resolution(v: Any) -> tuple[int, int]:
    if not isinstance(v, (list, tuple)) or len(v) != 2 or any(
            isinstance(x, bool) or not isinstance(x, numbers.Real) or not float(x).is_integer() for x in v):
        raise invalid(f"must be [rows, cols], two whole numbers, got {v!r}", allowed="[rows, cols], each >= 2")
    if v[0] < 2 or v[1] < 2:
        raise invalid(f"rows and cols must be >= 2, got {list(v)}", allowed="[rows, cols], each >= 2")
    return int(v[0]), int(v[1])


def _peak_qe(v: Any) -> float | tuple[float, float, float]:
    allowed = "0 < QE <= 1: one number, or [r, g, b]"
    vals = v if isinstance(v, (list, tuple)) else [v]
    if len(vals) not in (1, 3) or any(isinstance(q, bool) or not isinstance(q, numbers.Real) for q in vals):
        raise invalid(f"must be a number or 3 numbers [r, g, b], got {v!r}", allowed=allowed)
    if any(not (0 < q <= 1) for q in vals):
        raise invalid(f"peak QE must be in (0, 1], got {v!r}", allowed=allowed)
    return float(vals[0]) if not isinstance(v, (list, tuple)) else tuple(float(q) for q in vals)  # type: ignore


class _SensorSection(FileModel):
    name: str
    description: str = ""
    cfa_pattern: Literal["RGGB", "BGGR", "GRBG", "GBRG"]
    pixel_pitch_um: Annotated[Real, Field(gt=0.3, le=50)]
    resolution: Annotated[tuple[int, int], BeforeValidator(_resolution)]
    bit_depth: Annotated[Int, Field(ge=8, le=16)]
    black_level_dn: Annotated[Real, Field(ge=0)]

    @model_validator(mode="after")
    def _black_below_white(self) -> "_SensorSection":
        max_dn = 2 ** self.bit_depth - 1
        if self.black_level_dn >= max_dn:
            raise invalid(f"black level {self.black_level_dn:g} DN >= white level {max_dn}", field="black_level_dn",
                          allowed=f"0 … {max_dn - 1}")
        return self


class _SpectralSection(FileModel):
    file: str
    peak_qe: Annotated[float | tuple[float, float, float], BeforeValidator(_peak_qe)]
    ir_cut_file: str | None = None


class _NoiseSection(FileModel):
    full_well_e: Annotated[Real, Field(gt=0)]
    dark_current_e_per_s: Annotated[Real, Field(ge=0)]
    dark_current_ref_temp_c: Annotated[Real, Field(ge=-100, le=150)]
    dark_current_doubling_c: Annotated[Real, Field(gt=0)]
    prnu_percent: Annotated[Real, Field(ge=0, le=100)]
    dsnu_e: Annotated[Real, Field(ge=0)]


class _IsoEntry(FileModel):
    iso: Annotated[Real, Field(gt=0)]
    gain_dn_per_e: Annotated[Real, Field(gt=0)]
    read_noise_e: Annotated[Real, Field(ge=0)]


class _SensorFile(FileModel):
    """A sensor file (see the module docstring); every noise key must be cited in ``[sources]``."""

    sensor: _SensorSection
    spectral: _SpectralSection
    noise: _NoiseSection
    iso: list[_IsoEntry] = Field(min_length=1)
    sources: dict[str, str]

    @model_validator(mode="after")
    def _check(self) -> "_SensorFile":
        missing = [k for k in NOISE_KEYS if not self.sources.get(k, "").strip()]
        if missing:
            raise invalid(f"no source given for {', '.join(missing)}", field="sources",
                          allowed="a citation (URL, paper) or 'assumption: <reason>' for every noise key")
        unknown_src = sorted(set(self.sources) - set(NOISE_KEYS) - set(_SOURCE_EXTRA))
        if unknown_src:
            raise invalid(f"unknown key {unknown_src[0]!r}", field="sources",
                          allowed=", ".join(NOISE_KEYS + _SOURCE_EXTRA))
        isos = [e.iso for e in self.iso]
        if len(set(isos)) != len(isos):
            raise invalid("duplicate ISO entries", field="iso", allowed="distinct iso values")
        return self


# ---------------------------------------------------------------- typed description
@dataclass(frozen=True)
class IsoSetting:
    """One analog gain step of a sensor.

    Attributes
    ----------
    iso
        ISO setting (camera's own scale).
    gain_dn_per_e
        Overall system gain K (DN/e⁻), EMVA 1288.
    read_noise_e
        Input-referred temporal dark noise σ_d (e⁻ rms), read + ADC noise.
    """

    iso: float
    gain_dn_per_e: float
    read_noise_e: float


@dataclass(frozen=True, eq=False)
class Sensor:
    """A camera sensor in EMVA 1288 terms (see module docstring for the file format).

    Attributes
    ----------
    name
        Display name, e.g. ``"Sony ILCE-7RM2"``.
    wavelength_nm
        Wavelength grid of the QE table (nm).
    qe
        Absolute quantum efficiency (electrons per incident photon), shape
        (n_wavelengths, 3) for the R, G, B CFA channels, IR-cut filter included.
    cfa_pattern
        Colour of the top-left 2×2 block, e.g. ``"RGGB"``.
    pixel_pitch_um
        Pixel pitch (µm); pixel area = pitch².
    resolution
        (rows, cols) of the full sensor.
    full_well_e
        Saturation capacity (e⁻).
    dark_current_e_per_s, dark_current_ref_temp_c, dark_current_doubling_c
        Mean dark current (e⁻/s) at the reference temperature (°C) and the
        temperature step (°C) that doubles it.
    prnu_percent
        Photo-response non-uniformity, σ of the per-pixel gain map (% of signal).
    dsnu_e
        Dark-signal non-uniformity, σ of the per-pixel dark-offset map (e⁻).
    iso_settings
        Analog gain steps, sorted by ISO.
    bit_depth, black_level_dn
        ADC depth (bits) and black level offset (DN).
    sources
        Citation (or ``"assumption: …"``) for each parameter.
    file
        The sensor file it was read from (``None`` if built in code).
    """

    name: str
    wavelength_nm: np.ndarray
    qe: np.ndarray
    cfa_pattern: str
    pixel_pitch_um: float
    resolution: tuple[int, int]
    full_well_e: float
    dark_current_e_per_s: float
    dark_current_ref_temp_c: float
    dark_current_doubling_c: float
    prnu_percent: float
    dsnu_e: float
    iso_settings: tuple[IsoSetting, ...]
    bit_depth: int
    black_level_dn: float
    description: str = ""
    sources: dict = field(default_factory=dict)
    file: Path | None = None

    @property
    def white_level_dn(self) -> int:
        """Largest raw value (DN): 2**bit_depth − 1."""
        return 2 ** self.bit_depth - 1

    @property
    def pixel_area_m2(self) -> float:
        """Pixel area (m²)."""
        return (self.pixel_pitch_um * 1e-6) ** 2

    @property
    def base_iso(self) -> float:
        """Lowest ISO setting."""
        return self.iso_settings[0].iso

    def iso_setting(self, iso: float) -> IsoSetting:
        """Gain and read noise at ``iso``.

        A tabulated ISO is returned as is.  Between table entries the analog
        gain step below is used and K scales linearly with ISO (the camera's
        fine ISO steps are extra gain after the pixel); its read noise in e⁻ is
        kept, which is what photon-transfer measurements of DR-Pix sensors show
        within one conversion-gain mode (photonstophotos.net, Claff 2015).

        Raises
        ------
        ConfigError
            If ``iso`` is below the lowest tabulated ISO.
        """
        iso = float(iso)
        lo = self.iso_settings[0].iso
        if not np.isfinite(iso) or iso < lo:
            raise ConfigError(f"ISO {iso:g} is below the sensor's lowest ISO", field="iso",
                              allowed=f">= {lo:g} for {self.name}")
        below = [s for s in self.iso_settings if s.iso <= iso][-1]
        if below.iso == iso:
            return below
        return IsoSetting(iso=iso, gain_dn_per_e=below.gain_dn_per_e * iso / below.iso,
                          read_noise_e=below.read_noise_e)

    def qe_at(self, wavelength_nm) -> np.ndarray:
        """Absolute QE (e⁻/photon) at ``wavelength_nm``, shape (n, 3).

        Raises :class:`~rigsim.errors.SpectrumRangeError` outside the table.
        """
        wl = np.atleast_1d(np.asarray(wavelength_nm, float))
        return np.stack([interp_table(wl, self.wavelength_nm, self.qe[:, c],
                                      name=f"QE of {self.name}") for c in range(3)], axis=-1)

    def saturation_e(self, iso: float) -> float:
        """Electrons at which the raw value saturates at ``iso`` (full well or ADC)."""
        k = self.iso_setting(iso).gain_dn_per_e
        return min(self.full_well_e, (self.white_level_dn - self.black_level_dn) / k)

    def describe(self) -> dict:
        """JSON-serialisable summary (for ``capture.json``)."""
        return {"name": self.name, "file": str(self.file) if self.file else None,
                "cfa_pattern": self.cfa_pattern, "pixel_pitch_um": self.pixel_pitch_um,
                "resolution": list(self.resolution), "full_well_e": self.full_well_e,
                "bit_depth": self.bit_depth, "black_level_dn": self.black_level_dn,
                "dark_current_e_per_s": self.dark_current_e_per_s,
                "prnu_percent": self.prnu_percent, "dsnu_e": self.dsnu_e,
                "peak_qe": [float(q) for q in self.qe.max(axis=0)],
                "iso_settings": [vars(s) for s in self.iso_settings]}


def _resolve(rel: str, toml_path: Path, fld: str) -> Path:
    p = Path(rel)
    if p.is_absolute():
        cands = [p]
    else:
        cands = [toml_path.parent / p, DATA_DIR / p]
    for c in cands:
        if os.path.isfile(c):
            return c
    raise ConfigError(f"file {rel!r} not found (looked in {', '.join(str(c.parent) for c in cands)})",
                      file=toml_path, field=fld, allowed="a CSV beside the sensor file or in the data tree")


def _read_spectral_csv(path: Path, columns: tuple[str, ...], toml_path: Path, fld: str):
    try:
        t = read_csv_table(path)
        wl = t["wavelength_nm"]
        vals = np.stack([t[c] for c in columns], axis=-1)
    except DataError as exc:
        raise ConfigError(str(exc), file=toml_path, field=fld,
                          allowed=f"CSV with columns wavelength_nm,{','.join(columns)}") from None
    if wl.dtype.kind != "f" or vals.dtype.kind != "f" or np.any(~np.isfinite(vals)) \
            or np.any(np.diff(wl) <= 0):
        raise ConfigError(f"{path}: wavelengths must increase and values be numbers", file=toml_path,
                          field=fld, allowed="numeric CSV, strictly increasing wavelength_nm")
    if np.any(vals < 0):
        raise ConfigError(f"{path}: negative values", file=toml_path, field=fld, allowed=">= 0")
    return wl, vals


def load_sensor_file(path: str | Path) -> Sensor:
    """Read and validate a sensor TOML file.

    Raises
    ------
    ConfigError
        Naming the file, the field and the allowed values, for unknown keys,
        missing keys, out-of-range values, missing citations or unreadable CSVs.
    """
    path = Path(path)
    cfg = load_file(_SensorFile, path)
    isos = sorted(cfg.iso, key=lambda e: e.iso)

    wl, rel = _read_spectral_csv(_resolve(cfg.spectral.file, path, "spectral.file"),
                                 ("red", "green", "blue"), path, "spectral.file")
    peak = np.broadcast_to(np.asarray(cfg.spectral.peak_qe, float), (3,))
    rel_max = rel.max()
    qe = rel / rel_max * peak if np.ndim(cfg.spectral.peak_qe) == 0 else rel / rel.max(axis=0) * peak
    if cfg.spectral.ir_cut_file:
        fwl, fval = _read_spectral_csv(_resolve(cfg.spectral.ir_cut_file, path, "spectral.ir_cut_file"),
                                       ("value",), path, "spectral.ir_cut_file")
        if fwl[0] > wl[0] or fwl[-1] < wl[-1]:
            raise ConfigError(f"IR-cut filter covers {fwl[0]:g}–{fwl[-1]:g} nm, QE table "
                              f"{wl[0]:g}–{wl[-1]:g} nm", file=path, field="spectral.ir_cut_file",
                              allowed="a filter covering the QE table")
        qe = qe * np.interp(wl, fwl, fval[:, 0])[:, None]

    s = cfg.sensor
    n = cfg.noise
    return Sensor(name=s.name, description=s.description, wavelength_nm=wl, qe=qe,
                  cfa_pattern=s.cfa_pattern, pixel_pitch_um=s.pixel_pitch_um,
                  resolution=tuple(s.resolution), full_well_e=n.full_well_e,
                  dark_current_e_per_s=n.dark_current_e_per_s,
                  dark_current_ref_temp_c=n.dark_current_ref_temp_c,
                  dark_current_doubling_c=n.dark_current_doubling_c,
                  prnu_percent=n.prnu_percent, dsnu_e=n.dsnu_e,
                  iso_settings=tuple(IsoSetting(e.iso, e.gain_dn_per_e, e.read_noise_e) for e in isos),
                  bit_depth=s.bit_depth, black_level_dn=s.black_level_dn,
                  sources=dict(cfg.sources), file=path)


def available_sensors() -> list[str]:
    """Names (file stems) of the shipped sensor files."""
    return sorted(p.stem for p in SENSORS_DIR.glob("*.toml"))


@functools.lru_cache(maxsize=32)
def _load_cached(path: str, mtime: float) -> Sensor:
    return load_sensor_file(path)


def load_sensor(name_or_path: str | Path) -> Sensor:
    """Load a shipped sensor by name (``"sony_ilce-7rm2"``) or any sensor TOML by path.

    Raises
    ------
    ConfigError
        For an unknown name (suggesting close ones) or an invalid file.
    """
    p = Path(name_or_path)
    if p.suffix == ".toml" or os.path.isfile(p):
        if not os.path.isfile(p):
            raise ConfigError("sensor file not found", file=p, allowed="an existing .toml file")
    else:
        p = SENSORS_DIR / f"{name_or_path}.toml"
        if not os.path.isfile(p):
            raise unknown_name_error("sensor", str(name_or_path), available_sensors(), field="--sensor")
    p = p.resolve()
    return _load_cached(str(p), p.stat().st_mtime)
