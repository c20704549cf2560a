"""Named waters: the original write-up's six constituent presets, six code-derived ones, the ten Jerlov types.

* ``pure-sea``, ``clear``, ``coastal``, ``oceanic``, ``coastal-regions``,
  ``lakes-and-rivers`` — :class:`~rigsim.water.model.ConstituentWater` with the
  concentrations of the original write-up (Lian & Jobalia, "Underwater Rendering with
  Realistic Water Properties", section "Example Images"), ``data/water/presets_original.csv``.
* ``pure-water``, ``uwsim-clear-ocean``, ``uwsim-ocean``, ``coastal-petzold``,
  ``turbid-coastal``, ``turbid-lake`` — constituent waters rebuilt from the original
  *code*'s documented typical values (``data/water/presets_uwsim_code.csv``, see its header):
  a wider range of turbidity than the write-up's six.
* ``jerlov-I`` … ``jerlov-9C`` — :class:`~rigsim.water.model.TabulatedWater`
  with a(λ), b(λ) of Solonenko & Mobley (2015) (``data/water/
  jerlov_iop_solonenko_mobley_2015.csv``, 300–700 nm), phase function: pure water
  (b_w = 0.0017(550/λ)^4.3, Kopelevich) plus the Petzold average particle for the
  rest of b, weighted by each part's share of b(λ).

The published table has corrupt rows (3C at 675/700 nm, 5C at 600–700 nm) that the
data file leaves blank.  They are filled, and flagged in ``describe()``, by:
absorption — the type's last valid value times the geometric mean of the
relative change, over the same step, of the nearest types on either side that have valid values; scattering —
the power law ``b ∝ λ^−n`` fitted (least squares in log–log) to the type's own
400–575 nm values.

References
----------
.. [SM15] M.G. Solonenko, C.D. Mobley, "Inherent optical properties of Jerlov water
   types", Appl. Opt. 54(17):5392–5401 (2015).
.. [Je76] N.G. Jerlov, *Marine Optics*, Elsevier (1976).
"""

from __future__ import annotations

import functools

import numpy as np

from rigsim.data import load_table
from rigsim.errors import unknown_name_error
from rigsim.water.model import ConstituentWater, Spectrum1D, TabulatedWater, Water
from rigsim.water.phase import MixturePhase, RayleighWater, petzold_average_particle
from rigsim.water.scattering import scattering_pure_water

__all__ = ["ORIGINAL_PRESETS", "CODE_PRESETS", "JERLOV_TYPES", "WATER_PRESETS", "ALIASES", "preset",
           "preset_names", "jerlov_water"]

#: The six presets of the original write-up, in its order.
ORIGINAL_PRESETS = ("pure-sea", "clear", "coastal", "oceanic", "coastal-regions", "lakes-and-rivers")
#: Six constituent waters from the original code's documented values, clearest first.
CODE_PRESETS = ("pure-water", "uwsim-clear-ocean", "uwsim-ocean", "coastal-petzold", "turbid-coastal", "turbid-lake")
_TABLES = {**{n: "water/presets_original.csv" for n in ORIGINAL_PRESETS},
           **{n: "water/presets_uwsim_code.csv" for n in CODE_PRESETS}}
#: Jerlov types as named in the data (Roman oceanic, numbered coastal).
JERLOV_TYPES = ("I", "IA", "IB", "II", "III", "1C", "3C", "5C", "7C", "9C")

#: Alternative spellings accepted for preset names.
ALIASES = {
    "pure": "pure-sea", "pure-sea-water": "pure-sea", "clear-ocean": "clear",
    "coastal-ocean": "coastal", "lakes": "lakes-and-rivers", "rivers": "lakes-and-rivers",
    **{f"jerlov-{t.lower()}": f"jerlov-{t}" for t in JERLOV_TYPES},
    **{f"jerlov{t.lower()}": f"jerlov-{t}" for t in JERLOV_TYPES},
    **{f"jerlov-c{t[0]}": f"jerlov-{t}" for t in JERLOV_TYPES if t.endswith("C")},
}


def _constituent_rows() -> dict[str, dict]:
    rows = {}
    for table in sorted(set(_TABLES.values())):
        t = load_table(table)
        for i, name in enumerate(t["name"]):
            rows[str(name)] = {k: float(t[k][i]) for k in ("chl_mg_per_m3", "cdom_a440_per_m",
                                                            "small_particles_ppm", "large_particles_ppm")}
    return rows


def _jerlov_columns(water_type: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    t = load_table("water/jerlov_iop_solonenko_mobley_2015.csv")
    m = t["water_type"] == water_type
    return t["wavelength_nm"][m], t["a_per_m"][m], t["b_per_m"][m]


@functools.lru_cache(maxsize=None)
def _jerlov_filled() -> dict[str, tuple[np.ndarray, np.ndarray, np.ndarray, list[float]]]:
    """a(λ), b(λ) of each Jerlov type with the corrupt rows filled (see module docstring)."""
    out: dict[str, tuple] = {}
    for t in JERLOV_TYPES:
        wl, a, b = _jerlov_columns(t)
        out[t] = (wl.copy(), a.copy(), b.copy(), [])
    order = list(JERLOV_TYPES)
    # fill 3C before 5C so that 5C can lean on a filled 3C
    for t in ("3C", "5C"):
        wl, a, b, filled = out[t]
        i = order.index(t)
        for j in np.flatnonzero(np.isnan(a)):
            ref = j - 1
            while np.isnan(a[ref]):
                ref -= 1
            ratio = 1.0
            for step in (-1, 1):  # nearest type on each side valid at both wavelengths
                k = i + step
                while np.isnan(out[order[k]][1][j]) or np.isnan(out[order[k]][1][ref]):
                    k += step
                anb = out[order[k]][1]
                ratio *= anb[j] / anb[ref]
            a[j] = a[ref] * np.sqrt(ratio)
            filled.append(float(wl[j]))
        if filled:
            fit = (wl >= 400) & (wl <= 575) & ~np.isnan(b)
            slope, icpt = np.polyfit(np.log(wl[fit]), np.log(b[fit]), 1)
            nanb = np.isnan(b)
            b[nanb] = np.exp(icpt + slope * np.log(wl[nanb]))
    return out


@functools.lru_cache(maxsize=None)
def jerlov_water(water_type: str) -> TabulatedWater:
    """The Jerlov water type (``"I"`` … ``"9C"``) with Solonenko & Mobley (2015) IOPs."""
    if water_type not in JERLOV_TYPES:
        raise unknown_name_error("Jerlov type", water_type, JERLOV_TYPES, field="water")
    wl, a, b, filled = _jerlov_filled()[water_type]

    b_spec = Spectrum1D(values=b, wavelength_nm=wl, label=f"Jerlov {water_type} b (Solonenko & Mobley 2015)")

    def weights(w):
        bw = scattering_pure_water(w)
        btot = np.maximum(b_spec(w), bw)
        return np.stack([bw / btot, 1.0 - bw / btot], axis=-1)

    phase = MixturePhase([RayleighWater(), petzold_average_particle()], weights,
                         name="pure-water+petzold-average")
    return TabulatedWater(
        f"jerlov-{water_type}",
        Spectrum1D(values=a, wavelength_nm=wl, label=f"Jerlov {water_type} a (Solonenko & Mobley 2015)"),
        b_spec, phase,
        source="Solonenko & Mobley (2015) Tables 4-8",
        extra={"jerlov_type": water_type, "filled_wavelengths_nm": filled})


def preset_names() -> list[str]:
    """All preset names (the public interface)."""
    return list(ORIGINAL_PRESETS) + list(CODE_PRESETS) + [f"jerlov-{t}" for t in JERLOV_TYPES]


#: Name → short description, for listings.
WATER_PRESETS = {
    **{n: "original write-up preset (constituents)" for n in ORIGINAL_PRESETS},
    **{n: "from the original code's documented values (constituents)" for n in CODE_PRESETS},
    **{f"jerlov-{t}": f"Jerlov type {t} (Solonenko & Mobley 2015 IOPs)" for t in JERLOV_TYPES},
}


def preset(name: str, **model_options) -> Water:
    """A named water.  Constituent presets accept :class:`ConstituentWater` model options
    (``pure_water=``, ``detritus_exponent=``, ``phytoplankton=``) and concentration overrides.

    Examples
    --------
    >>> preset("coastal").small_particles_ppm
    0.1
    >>> preset("coastal-petzold").large_particles_ppm
    0.3
    """
    key = ALIASES.get(name.lower(), name) if name not in WATER_PRESETS else name
    if key in _TABLES:
        params = dict(_constituent_rows()[key])
        params.update(model_options)
        return ConstituentWater(name=key, **params)
    if key.startswith("jerlov-") and key[7:] in JERLOV_TYPES:
        if model_options:
            raise unknown_name_error("option for a Jerlov preset", next(iter(model_options)), [], field="water")
        return jerlov_water(key[7:])
    raise unknown_name_error("water preset", name, preset_names(), field="water")
