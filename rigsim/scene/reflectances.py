"""Reflectance spectra of the test targets (Lambertian, 0–1, tabulated 360–830 nm every 5 nm).

* ColorChecker: N. Ohta's measurements (as shipped with colour-science,
  ``colour.SDS_COLOURCHECKERS["ColorChecker N Ohta"]``, 380–780 nm every 5 nm), **edge-held**
  to 360–830 nm (:func:`reflectance_colorchecker_Ohta`);
* black 4 %, white 90 % (a matte white paint/board; a Spectralon-type standard would be ~99 %)
  — stated values, not measurements (:data:`BLACK_REFLECTANCE`, :data:`WHITE_REFLECTANCE`);
* sea-bottom types measured by Maritorena, Morel & Gentili (1994): coral sand, green, brown and red
  (coralline) algae, 350–800 nm, held to 830 nm (``data/targets/benthic_maritorena_1994.csv``;
  :func:`reflectance_benthic_Maritorena1994`) — the coral sand of the ``bottom`` plane and the
  seabed, the rocks' covers;
* a user's CSV ``wavelength_nm, reflectance`` (:func:`reflectance_from_csv`).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from rigsim.data import load_table, read_csv_table
from rigsim.errors import ConfigError, DataError

__all__ = ["REFLECTANCE_WAVELENGTHS_NM", "BLACK_REFLECTANCE", "WHITE_REFLECTANCE", "MESH_DEFAULT_REFLECTANCE",
           "reflectance_colorchecker_Ohta", "reflectance_benthic_Maritorena1994",
           "reflectance_from_csv"]

#: Wavelengths at which target reflectances are tabulated (nm): 360–830, 5 nm.
REFLECTANCE_WAVELENGTHS_NM = np.arange(360.0, 830.0 + 0.5, 5.0)

BLACK_REFLECTANCE = 0.04        #: Black disk / chart body / black half of the edge target (stated, not measured).
WHITE_REFLECTANCE = 0.90        #: White disk / white half of the edge target (a matte white board, stated).
MESH_DEFAULT_REFLECTANCE = 0.18  #: Grey for meshes without a reflectance.


def _hold(wl_table, values, wavelength_nm) -> np.ndarray:
    return np.interp(np.asarray(wavelength_nm, float), wl_table, values)


def reflectance_colorchecker_Ohta(wavelength_nm=REFLECTANCE_WAVELENGTHS_NM) -> dict[str, np.ndarray]:
    """ColorChecker patch reflectances (N. Ohta 1997), chart order, edge-held outside 380–780 nm.

    The data are colour-science's ``SDS_COLOURCHECKERS["ColorChecker N Ohta"]`` (380–780 nm,
    5 nm), interpolated linearly.

    Returns
    -------
    dict
        Patch name → reflectance (0–1) at ``wavelength_nm``; 24 entries in chart
        order (row-major from the top-left, ``dark skin`` … ``black 2 (1.5 D)``).
    """
    import colour

    sds = colour.SDS_COLOURCHECKERS["ColorChecker N Ohta"]
    return {n: _hold(sd.wavelengths, sd.values, wavelength_nm) for n, sd in sds.items()}


def reflectance_benthic_Maritorena1994(wavelength_nm=REFLECTANCE_WAVELENGTHS_NM) -> dict[str, np.ndarray]:
    """Sea-bottom reflectances of Maritorena, Morel & Gentili (1994), Limnol. Oceanogr. 39(7):1689–1703,
    Fig. 6: ``coral_sand``, ``green_algae``, ``brown_algae``, ``red_algae`` (0–1) at ``wavelength_nm``,
    edge-held outside 350–800 nm (see the data file's header for the species)."""
    t = load_table("targets/benthic_maritorena_1994.csv")
    return {k: _hold(t["wavelength_nm"], t[k], wavelength_nm)
            for k in ("coral_sand", "green_algae", "brown_algae", "red_algae")}


def reflectance_from_csv(path: str | Path, wavelength_nm=REFLECTANCE_WAVELENGTHS_NM) -> np.ndarray:
    """A reflectance CSV (``wavelength_nm, reflectance``, 0–1, covering 400–700 nm), edge-held."""
    p = Path(path)
    if not os.path.isfile(p):
        raise ConfigError("reflectance file not found", file=p,
                          allowed="a CSV with columns wavelength_nm, reflectance")
    try:
        t = read_csv_table(p)
    except DataError as exc:
        raise ConfigError(f"cannot read reflectance: {exc}", file=p) from None
    if "wavelength_nm" not in t.columns or "reflectance" not in t.columns:
        raise ConfigError("needs columns wavelength_nm, reflectance", file=p,
                          allowed="columns wavelength_nm, reflectance")
    wl, r = t.columns["wavelength_nm"], t.columns["reflectance"]
    if wl.dtype.kind != "f" or r.dtype.kind != "f" or not (np.all(np.isfinite(wl)) and np.all(np.isfinite(r))):
        raise ConfigError("non-numeric or blank values", file=p)
    if wl.size < 2 or np.any(np.diff(wl) <= 0) or wl[0] > 400 or wl[-1] < 700:
        raise ConfigError("wavelengths must increase and cover 400–700 nm", file=p,
                          allowed="increasing wavelengths covering 400–700 nm")
    if np.any(r < 0) or np.any(r > 1):
        raise ConfigError("reflectance must be within 0–1", file=p, allowed="0 <= reflectance <= 1")
    return _hold(wl, r, wavelength_nm)
