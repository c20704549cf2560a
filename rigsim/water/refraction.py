"""Refraction at the water's interfaces (the sea surface, a housing port): index, Snell, Fresnel.

The one place for the refractive index of sea water and the plane-interface laws that
both the daylight models (the sea surface) and the camera's port (water → glass → air)
use.

References
----------
.. [BW99] M. Born, E. Wolf, *Principles of Optics*, 7th ed., Cambridge (1999), §1.5.
.. [QF95] X. Quan, E.S. Fry, "Empirical equation for the index of refraction of seawater",
   Appl. Opt. 34(18):3477–3480 (1995): n = 1.3394 at 550 nm, 20 °C, salinity 35 ‰
   (1.3435 at 400 nm, 1.3372 at 700 nm).
.. [Mo94] C.D. Mobley, *Light and Water*, Academic Press (1994), §3.6 and §4.3 (n ≈ 1.34
   for sea water; R(0) = 0.0211 for a level surface).
"""

from __future__ import annotations

import numpy as np

__all__ = ["WATER_INDEX", "fresnel_reflectance_unpolarised", "snell_cos_transmitted"]

#: Refractive index of sea water (dimensionless), 1.34 [Mo94]; [QF95] gives 1.3394 at 550 nm,
#: 20 °C, 35 ‰ and a spread of ±0.3 % over 400–700 nm, which rigsim neglects (no dispersion).
#: Used for the sun's refraction at the surface, the surface's Fresnel reflectance, and the
#: camera port's refraction and transmittance.
WATER_INDEX = 1.34


def fresnel_reflectance_unpolarised(cos_incident, n1: float = 1.0, n2: float = WATER_INDEX) -> np.ndarray:
    """Fresnel reflectance of unpolarised light at a plane interface [BW99].

    ``R = (r_s² + r_p²)/2`` with ``r_s = (n1 cos i − n2 cos t)/(n1 cos i + n2 cos t)``,
    ``r_p = (n2 cos i − n1 cos t)/(n2 cos i + n1 cos t)``; ``R = 1`` beyond the critical
    angle (total internal reflection).

    Parameters
    ----------
    cos_incident
        Cosine of the angle of incidence, measured from the normal, in [0, 1].
    n1, n2
        Refractive index on the incident and on the transmitted side (air → water:
        1, 1.34; water → air: 1.34, 1).

    Returns
    -------
    numpy.ndarray
        Reflectance in [0, 1].

    Examples
    --------
    >>> round(float(fresnel_reflectance_unpolarised(1.0)), 4)   # ((n-1)/(n+1))^2
    0.0211
    >>> float(fresnel_reflectance_unpolarised(0.5, 1.34, 1.0))  # 60 deg from below: TIR
    1.0
    """
    ci = np.clip(np.abs(np.asarray(cos_incident, float)), 0.0, 1.0)
    eta = n1 / n2
    sin2_t = eta * eta * (1.0 - ci * ci)
    tir = sin2_t >= 1.0
    ct = np.sqrt(np.clip(1.0 - sin2_t, 0.0, 1.0))
    with np.errstate(invalid="ignore", divide="ignore"):
        rs = (n1 * ci - n2 * ct) / (n1 * ci + n2 * ct)
        rp = (n2 * ci - n1 * ct) / (n2 * ci + n1 * ct)
        r = 0.5 * (rs * rs + rp * rp)
    r = np.where(ci == 0.0, 1.0, r)
    return np.where(tir, 1.0, r)


def snell_cos_transmitted(cos_incident, n1: float = 1.0, n2: float = WATER_INDEX) -> np.ndarray:
    """Cosine of the refraction angle, ``sqrt(1 − (n1/n2)² sin² i)``; NaN beyond the critical angle."""
    ci = np.clip(np.abs(np.asarray(cos_incident, float)), 0.0, 1.0)
    s2 = (n1 / n2) ** 2 * (1.0 - ci * ci)
    with np.errstate(invalid="ignore"):
        return np.where(s2 <= 1.0, np.sqrt(1.0 - s2), np.nan)


