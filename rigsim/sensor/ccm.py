"""Colour correction matrix (camera RGB → linear sRGB) fitted on the ColorChecker.

The ColorChecker (``colour.SDS_COLOURCHECKERS['ColorChecker N Ohta']``) is
"photographed" by the sensor under an illuminant: camera RGB of each patch is
Σ R(λ)·E(λ)·η_c(λ)·λ (photon counting).  After white balance on the perfect
white reflector, a 3×3 matrix is fitted by least squares with colour-science
(``colour.characterisation.matrix_colour_correction``) to the patches' linear
sRGB (the XYZ under the illuminant, Bradford-adapted to D65).  Rows are then
normalised to sum to one, so that white stays white (and the matrix is what a
DNG ColorMatrix + AsShotNeutral pair encodes).

References
----------
Finlayson, G. D., Mackiewicz, M., Hurlbert, A. (2015). Color correction using
  root-polynomial regression. IEEE Trans. Image Process. 24(5), 1460–1470 (degree 1 =
  linear 3×3 least squares).
Ohta, N. — ColorChecker reflectances as shipped with colour-science.
"""

from __future__ import annotations

import threading
import weakref

import numpy as np

from rigsim.errors import ConfigError

#: Index of the neutral patches in the ColorChecker (19 white 9.5 … 24 black 2).
NEUTRAL_PATCHES = {"white": 18, "neutral 8": 19, "neutral 6.5": 20, "neutral 5": 21,
                   "neutral 3.5": 22, "black": 23}

_STEP_NM = 5.0


def _grid(sensor) -> np.ndarray:
    lo = max(380.0, float(sensor.wavelength_nm[0]))
    hi = min(780.0, float(sensor.wavelength_nm[-1]))
    return np.arange(np.ceil(lo / _STEP_NM) * _STEP_NM, hi + 1e-9, _STEP_NM)


def colorchecker_reflectances(wavelength_nm) -> np.ndarray:
    """(24, n) ColorChecker N Ohta reflectances at ``wavelength_nm`` (nm), chart order, edge-held
    (:func:`rigsim.scene.reflectances.reflectance_colorchecker_Ohta`)."""
    from rigsim.scene.reflectances import reflectance_colorchecker_Ohta

    return np.array(list(reflectance_colorchecker_Ohta(np.asarray(wavelength_nm, float)).values()))


def illuminant_spd(name_or_values, wavelength_nm) -> np.ndarray:
    """Relative spectral power of a CIE illuminant by name (``"D65"``, ``"A"`` …) or given values."""
    import colour

    if isinstance(name_or_values, str):
        try:
            sd = colour.SDS_ILLUMINANTS[name_or_values]
        except KeyError:
            from rigsim.errors import unknown_name_error

            raise unknown_name_error("illuminant", name_or_values, colour.SDS_ILLUMINANTS.keys(),
                                     field="illuminant") from None
        return np.interp(wavelength_nm, sd.wavelengths, sd.values)
    v = np.asarray(name_or_values, float)
    if v.shape != np.shape(wavelength_nm):
        raise ConfigError("illuminant values and wavelengths differ in length", field="illuminant")
    return v


def colorchecker_camera_rgb(sensor, illuminant="D65", wavelength_nm=None) -> np.ndarray:
    """(25, 3) camera RGB of the 24 patches and a perfect white (last row), white G = 1."""
    wl = _grid(sensor) if wavelength_nm is None else np.asarray(wavelength_nm, float)
    e = illuminant_spd(illuminant, wl)
    refl = np.vstack([colorchecker_reflectances(wl), np.ones_like(wl)])
    rgb = (refl * (e * wl)) @ sensor.qe_at(wl)
    return rgb / rgb[-1, 1]


def colorchecker_reference_srgb(illuminant="D65", wavelength_nm=None) -> np.ndarray:
    """(25, 3) linear sRGB (D65) of the patches and a perfect white (= 1) seen under ``illuminant``,
    chromatically adapted to D65 (Bradford)."""
    import colour

    from rigsim.colorimetry import XYZ_from_bands

    wl = np.arange(380.0, 781.0, _STEP_NM) if wavelength_nm is None else np.asarray(wavelength_nm, float)
    e = illuminant_spd(illuminant, wl)
    refl = np.vstack([colorchecker_reflectances(wl), np.ones_like(wl)])
    xyz = XYZ_from_bands(refl, wl, illuminant=e)  # perfect white: Y = 1
    white = xyz[-1]
    d65 = colour.xy_to_XYZ(colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["D65"])
    xyz = colour.adaptation.chromatic_adaptation_VonKries(xyz, white, d65, transform="Bradford")
    return colour.XYZ_to_sRGB(xyz, apply_cctf_encoding=False)


def fit_ccm(camera_rgb_wb: np.ndarray, reference_srgb: np.ndarray, *, white_weight: int = 24) -> np.ndarray:
    """3×3 matrix M with ``reference ≈ camera_rgb_wb @ M.T``, rows summing to 1.

    The last rows of both inputs are taken as the white; it is repeated
    ``white_weight`` times in the least-squares fit (colour-science
    ``matrix_colour_correction``, Finlayson 2015 degree 1).
    """
    import colour

    cam = np.asarray(camera_rgb_wb, float)
    ref = np.asarray(reference_srgb, float)
    cam = np.vstack([cam, np.repeat(cam[-1:], white_weight, axis=0)])
    ref = np.vstack([ref, np.repeat(ref[-1:], white_weight, axis=0)])
    m = np.asarray(colour.characterisation.matrix_colour_correction(cam, ref, method="Finlayson 2015",
                                                                  degree=1), float)
    return m / m.sum(axis=1, keepdims=True)


#: Fitted CCMs per sensor object and illuminant name; an entry goes when its sensor does
#: (sensors are immutable, and compare by identity).
_CCMS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
_CCMS_LOCK = threading.Lock()


def _fit_ccm_ColorChecker(sensor, illuminant: str) -> np.ndarray:
    rgb = colorchecker_camera_rgb(sensor, illuminant)
    wb = rgb * (rgb[-1, 1] / rgb[-1])  # perfect white → (1, 1, 1)
    ref = colorchecker_reference_srgb(illuminant)
    return fit_ccm(wb, ref)


def ccm_ColorChecker(sensor, illuminant: str = "D65") -> np.ndarray:
    """CCM of ``sensor`` fitted on the ColorChecker under the CIE ``illuminant`` (cached).

    The fit is kept, per illuminant, as long as the ``sensor`` object lives.

    Returns
    -------
    ndarray
        3×3 matrix: linear sRGB = M @ white-balanced camera RGB.
    """
    with _CCMS_LOCK:
        m = _CCMS.get(sensor, {}).get(illuminant)
    if m is None:
        m = _fit_ccm_ColorChecker(sensor, illuminant)
        with _CCMS_LOCK:
            _CCMS.setdefault(sensor, {})[illuminant] = m
    return m.copy()


def ccm_from_xyz_to_camera(xyz_to_cam: np.ndarray) -> np.ndarray:
    """CCM (white-balanced camera → linear sRGB) from an XYZ → camera matrix (DNG ColorMatrix,
    LibRaw ``rgb_xyz_matrix``), the dcraw way: cam_rgb = xyz_cam · M_sRGB→XYZ, rows normalised
    to sum to 1, then inverted."""
    import colour

    m_rgb2xyz = colour.models.RGB_COLOURSPACE_sRGB.matrix_RGB_to_XYZ
    cam_rgb = np.asarray(xyz_to_cam, float)[:3, :3] @ m_rgb2xyz
    s = cam_rgb.sum(axis=1, keepdims=True)
    if np.any(np.abs(s) < 1e-12) or not np.all(np.isfinite(cam_rgb)):
        raise ConfigError("colour matrix is singular or missing", field="ColorMatrix")
    return np.linalg.inv(cam_rgb / s)


def xyz_to_camera_from_ccm(ccm: np.ndarray, wb_gains) -> np.ndarray:
    """DNG ColorMatrix (XYZ → camera native) encoding ``ccm`` and the neutral 1/``wb_gains``.

    Inverse of :func:`ccm_from_xyz_to_camera` for a white-preserving ``ccm``.
    """
    import colour

    m_rgb2xyz = colour.models.RGB_COLOURSPACE_sRGB.matrix_RGB_to_XYZ
    cam_to_xyz = m_rgb2xyz @ np.asarray(ccm, float) @ np.diag(np.asarray(wb_gains, float))
    cm = np.linalg.inv(cam_to_xyz)
    d65 = colour.xy_to_XYZ(colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["D65"])
    return cm / (cm @ d65).max()


def delta_E_ColorChecker(srgb_linear: np.ndarray, illuminant="D65") -> np.ndarray:
    """CIEDE2000 of 24 measured linear-sRGB patch colours against the reference, (24,)."""
    import colour

    ref = colorchecker_reference_srgb(illuminant)[:24]
    d65 = colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["D65"]
    lab = lambda rgb: colour.XYZ_to_Lab(colour.sRGB_to_XYZ(rgb, apply_cctf_decoding=False), d65)
    return colour.delta_E(lab(ref), lab(np.asarray(srgb_linear, float)), method="CIE 2000")
