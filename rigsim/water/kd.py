"""Diffuse attenuation coefficient of downwelling irradiance Kd(λ) from the IOPs, 1/m.

References
----------
.. [Le05] Z.-P. Lee, K.-P. Du, R. Arnone, "A model for the diffuse attenuation
   coefficient of downwelling irradiance", J. Geophys. Res. 110, C02016 (2005), eq. 11.
.. [Go89] H.R. Gordon, "Can the Lambert-Beer law be applied to the diffuse
   attenuation coefficient of ocean water?", Limnol. Oceanogr. 34(8):1389–1409 (1989).
"""

from __future__ import annotations

import numpy as np

from rigsim.errors import ConfigError, unknown_name_error
from rigsim.water.refraction import WATER_INDEX

__all__ = ["kd_Lee2005", "kd_Gordon1989", "KD_METHODS", "kd", "refracted_zenith_deg"]


def refracted_zenith_deg(sun_zenith_deg: float, n_water: float = WATER_INDEX) -> float:
    """Zenith angle (deg) of the sun's direct beam below a flat surface (Snell)."""
    z = float(sun_zenith_deg)
    if not 0.0 <= z < 90.0:
        raise ConfigError(f"sun zenith must be in [0, 90) deg, got {z}", field="sun_zenith_deg",
                          allowed="0 ≤ zenith < 90")
    return float(np.degrees(np.arcsin(np.sin(np.radians(z)) / n_water)))


def kd_Lee2005(a_per_m, bb_per_m, sun_zenith_deg: float = 0.0) -> np.ndarray:
    """Kd = (1 + 0.005 θs) a + 4.18 (1 − 0.52 exp(−10.8 a)) b_b   [Le05, eq. 11], 1/m.

    θs is the solar zenith angle above the surface in degrees.  The model was fit
    to Hydrolight runs for the layer from the surface to the 10 % light level.
    """
    a = np.asarray(a_per_m, float)
    bb = np.asarray(bb_per_m, float)
    refracted_zenith_deg(sun_zenith_deg)  # validates the angle
    return (1.0 + 0.005 * float(sun_zenith_deg)) * a + 4.18 * (1.0 - 0.52 * np.exp(-10.8 * a)) * bb


def kd_Gordon1989(a_per_m, bb_per_m, sun_zenith_deg: float = 0.0) -> np.ndarray:
    """Kd = 1.0395 (a + b_b) / μ_w   [Go89], with μ_w the cosine of the refracted sun, 1/m."""
    mu_w = np.cos(np.radians(refracted_zenith_deg(sun_zenith_deg)))
    return 1.0395 * (np.asarray(a_per_m, float) + np.asarray(bb_per_m, float)) / mu_w


#: Kd models by name (first is the default).
KD_METHODS = {"lee-2005": kd_Lee2005, "gordon-1989": kd_Gordon1989}


def kd(a_per_m, bb_per_m, sun_zenith_deg: float = 0.0, method: str = "lee-2005") -> np.ndarray:
    """Kd(λ) by model name, one of :data:`KD_METHODS`."""
    try:
        fn = KD_METHODS[method]
    except KeyError:
        raise unknown_name_error("Kd model", method, KD_METHODS, field="kd_method") from None
    return fn(a_per_m, bb_per_m, sun_zenith_deg)
