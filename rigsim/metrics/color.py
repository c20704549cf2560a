"""Colour difference of the ColorChecker patches (CIEDE2000 through colour-science)."""

from __future__ import annotations

import numpy as np

__all__ = ["delta_e_2000", "chart_delta_e"]


def delta_e_2000(reference_lab: np.ndarray, test_lab: np.ndarray) -> np.ndarray:
    """CIEDE2000 colour difference of CIE L*a*b* values (``colour.delta_E(..., method="CIE 2000")``)."""
    import colour

    return np.asarray(colour.delta_E(np.asarray(reference_lab, float), np.asarray(test_lab, float),
                                     method="CIE 2000"))


def chart_delta_e(reference_xyz: np.ndarray, test_xyz: np.ndarray, *,
                  illuminant_xy=None) -> tuple[float, np.ndarray]:
    """Mean and per-patch ΔE2000 of a chart, from XYZ (Y of the white = 1).

    Parameters
    ----------
    reference_xyz, test_xyz
        (patches, 3) tristimulus values; both relative to the same white.
    illuminant_xy
        Chromaticity of the reference white for the Lab conversion (default D65).
    """
    import colour

    if illuminant_xy is None:
        illuminant_xy = colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["D65"]
    ref = colour.XYZ_to_Lab(np.asarray(reference_xyz, float), illuminant_xy)
    tst = colour.XYZ_to_Lab(np.asarray(test_xyz, float), illuminant_xy)
    de = delta_e_2000(ref, tst)
    return float(np.mean(de)), de
