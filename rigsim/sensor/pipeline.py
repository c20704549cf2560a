"""SpectralImage → Capture: optics, EMVA 1288 sensor, and the image-processing chain.

:func:`capture` turns a :class:`~rigsim.spectral_image.SpectralImage` into a
:class:`Capture` (electrons, raw DN mosaic) and, unless ``develop=None``,
develops it with :func:`develop`: black subtraction → white balance on the
mosaic → demosaicing → colour correction matrix → linear sRGB → 8-bit sRGB.
A real raw file read by :func:`rigsim.sensor.raw_io.read_raw` is a Capture too
and goes through the same :func:`develop`.
"""

from __future__ import annotations

import dataclasses
import logging
import time
from dataclasses import dataclass, field

import numpy as np

from rigsim.errors import ConfigError
from rigsim.sensor.cfa import check_pattern, mosaic, pattern_codes
from rigsim.sensor.ccm import ccm_ColorChecker
from rigsim.sensor.demosaic import demosaic as _demosaic
from rigsim.sensor.model import Sensor
from rigsim.sensor.noise import NoiseSwitches, digitise_emva1288, electrons_emva1288
from rigsim.sensor.optics import Lens, electrons_per_radiance, port_factor_map, vignetting_map
from rigsim.sensor.white_balance import white_balance_gains

log = logging.getLogger(__name__)


#: Highest ISO an exposure may ask for (cameras reach about 4 million).
MAX_ISO = 1e7


@dataclass(frozen=True)
class Exposure:
    """Exposure settings.

    Attributes
    ----------
    exposure_time_s
        Shutter time (s, > 0).
    iso
        ISO setting (selects K and read noise, see :meth:`Sensor.iso_setting`).
    lens
        The lens (f-number, transmittance, vignetting).
    temperature_c
        Sensor temperature (°C) for the dark current; ``None``: the sensor's reference.
    flash_scale
        Fraction of the strobes' configured output fired (what a strobe's power setting
        or TTL chooses; 1 = as in the rig file).  It scales the render's ``flash`` layer;
        a flash is shorter than any shutter time, so the shutter does not scale it.
    """

    exposure_time_s: float
    iso: float
    lens: Lens = Lens()
    temperature_c: float | None = None
    flash_scale: float = 1.0

    def __post_init__(self):
        if not (np.isfinite(self.exposure_time_s) and 0 < self.exposure_time_s <= 3600):
            raise ConfigError(f"shutter time must be in (0, 3600] s, got {self.exposure_time_s}",
                              field="shutter", allowed="(0, 3600] s")
        if not (np.isfinite(self.iso) and 0 < self.iso <= MAX_ISO):
            raise ConfigError(f"ISO must be in (0, {MAX_ISO:g}], got {self.iso:g}", field="iso",
                              allowed=f"(0, {MAX_ISO:g}]")
        if not (np.isfinite(self.flash_scale) and self.flash_scale >= 0):
            raise ConfigError(f"flash scale must be >= 0, got {self.flash_scale}", field="flash_scale",
                              allowed=">= 0 (1 = the rig's strobe output)")

    def describe(self) -> dict:
        return {"exposure_time_s": self.exposure_time_s, "iso": self.iso,
                "f_number": self.lens.f_number, "f_number_source": self.lens.f_number_source,
                "lens_transmittance": self.lens.transmittance,
                "vignetting": self.lens.vignetting, "temperature_c": self.temperature_c,
                "flash_scale": self.flash_scale}


@dataclass(frozen=True)
class DevelopOptions:
    """Image-processing choices.

    Attributes
    ----------
    demosaic
        A key of :data:`rigsim.sensor.demosaic.DEMOSAICING_METHODS`.
    white_balance
        A key of :data:`rigsim.sensor.white_balance.WHITE_BALANCE_METHODS` or ``"as_shot"``
        (the capture's own neutral, e.g. from a raw file).
    wb_kwargs
        Arguments of the white balance method (``box=`` for ``chart``, ``gains=`` for
        ``manual``, spectra for ``illuminant``).
    ccm
        3×3 camera → linear sRGB matrix; ``None``: the capture's own (sensor's ColorChecker fit
        under D65, or the raw file's colour matrix).
    gain
        Digital gain applied to the linear image before encoding (1 = none).
    """

    demosaic: str = "Malvar2004"
    white_balance: str = "grayworld"
    wb_kwargs: dict = field(default_factory=dict)
    ccm: np.ndarray | None = None
    gain: float = 1.0

    def describe(self) -> dict:
        kw = {k: (np.asarray(v).tolist() if isinstance(v, (np.ndarray, list, tuple)) else v)
              for k, v in self.wb_kwargs.items() if k != "sensor"}
        return {"demosaic": self.demosaic, "white_balance": self.white_balance, "wb_kwargs": kw,
                "ccm": None if self.ccm is None else np.asarray(self.ccm).tolist(), "gain": self.gain}


@dataclass(frozen=True, eq=False)
class Capture:
    """What a camera records, and its development.

    Attributes
    ----------
    raw
        (rows, cols) uint16 raw DN mosaic.
    cfa_pattern
        Top-left 2×2 CFA pattern (``"RGGB"`` …).
    black_level
        (4,) black level (DN) of the four sites of the 2×2 block, row-major.
    white_level
        Saturation value (DN).
    electrons
        (rows, cols) float32 collected electrons (simulation only; ``None`` for real files).
    exposure
        The exposure that made it (``None`` if unknown).
    sensor
        The sensor that made it (``None`` for real files; see ``camera``).
    camera
        Camera name.
    as_shot_neutral
        Camera RGB of a neutral under the scene light (G = 1), if known.
    ccm
        Default camera → linear sRGB matrix (3×3).
    wb_gains
        White balance gains (R, G, B) used by the development.
    linear_rgb
        (rows, cols, 3) float32 scene-linear sRGB (D65 primaries), white level → 1.
    srgb
        (rows, cols, 3) uint8 sRGB-encoded image.
    meta
        Seeds, noise switches, develop options, timings.
    """

    raw: np.ndarray
    cfa_pattern: str
    black_level: np.ndarray
    white_level: float
    electrons: np.ndarray | None = None
    exposure: Exposure | None = None
    sensor: Sensor | None = None
    camera: str = ""
    as_shot_neutral: np.ndarray | None = None
    ccm: np.ndarray | None = None
    wb_gains: np.ndarray | None = None
    linear_rgb: np.ndarray | None = None
    srgb: np.ndarray | None = None
    meta: dict = field(default_factory=dict)

    @property
    def shape(self) -> tuple[int, int]:
        return self.raw.shape

    def normalised_mosaic(self, gains=None) -> np.ndarray:
        """(raw − black) / (white − black) as float32 (per CFA site black level), times the
        per-channel ``gains`` (R, G, B) if given."""
        bl = np.asarray(self.black_level, np.float64).reshape(2, 2)
        codes = pattern_codes(self.cfa_pattern)
        out = self.raw.astype(np.float32)
        for dy in (0, 1):
            for dx in (0, 1):
                g = 1.0 if gains is None else float(gains[codes[dy, dx]])
                site = out[dy::2, dx::2]
                site -= np.float32(bl[dy, dx])
                site *= np.float32(g / (self.white_level - bl[dy, dx]))
        return out

    def half_rgb(self) -> np.ndarray:
        """Half-resolution normalised camera RGB from 2×2 blocks (R, mean G, B); for statistics."""
        bl = np.asarray(self.black_level, np.float64).reshape(2, 2)
        codes = pattern_codes(self.cfa_pattern)
        r2, c2 = self.raw.shape[0] // 2 * 2, self.raw.shape[1] // 2 * 2
        out = np.zeros((r2 // 2, c2 // 2, 3), np.float32)
        for dy in (0, 1):
            for dx in (0, 1):
                site = self.raw[dy:r2:2, dx:c2:2].astype(np.float32)
                site -= np.float32(bl[dy, dx])
                site *= np.float32((0.5 if codes[dy, dx] == 1 else 1.0) / (self.white_level - bl[dy, dx]))
                out[..., codes[dy, dx]] += site
        return out

    def describe(self) -> dict:
        """JSON-serialisable summary (for ``capture.json``)."""
        d = {"camera": self.camera, "shape": list(self.raw.shape), "cfa_pattern": self.cfa_pattern,
             "black_level": np.asarray(self.black_level).tolist(), "white_level": self.white_level,
             "exposure": self.exposure.describe() if self.exposure else None,
             "sensor": self.sensor.describe() if self.sensor else None,
             "as_shot_neutral": None if self.as_shot_neutral is None else np.asarray(self.as_shot_neutral).tolist(),
             "ccm": None if self.ccm is None else np.asarray(self.ccm).tolist(),
             "wb_gains": None if self.wb_gains is None else np.asarray(self.wb_gains).tolist()}
        if self.electrons is not None:
            codes = pattern_codes(self.cfa_pattern)
            d["mean_electrons_rgb"] = [float(np.mean([self.electrons[dy::2, dx::2].mean()
                                                      for dy in (0, 1) for dx in (0, 1) if codes[dy, dx] == c]))
                                       for c in range(3)]
            d["raw_saturated_fraction"] = float(np.mean(self.raw >= self.white_level))
        d.update(self.meta)
        return d


# ---------------------------------------------------------------- optics + sensor
def mean_electrons_rgb(spectral_image, sensor: Sensor, exposure: Exposure) -> np.ndarray:
    """(rows, cols, 3) float32 mean photo-electrons per pixel if each pixel had each CFA filter.

    Camera equation (see :mod:`rigsim.sensor.optics`) with the sensor's pixel area and the
    housing port (:func:`~rigsim.sensor.optics.port_factor_map`, from the image's typed scene),
    applied to the radiant exposure: continuous radiance × shutter time plus ``flash_scale`` × the
    render's ``flash`` layer (strobes).  cos⁴ vignetting of the image's camera if
    ``exposure.lens.vignetting`` (:func:`~rigsim.sensor.optics.vignetting_map`).
    """
    si = spectral_image
    e = _electrons_parts(si, sensor, exposure)
    return (e[0] * np.float32(exposure.exposure_time_s) + e[1] * np.float32(exposure.flash_scale)).astype(np.float32)


#: the last few :func:`_electrons_parts` results: {(id(image), id(sensor), lens): (image, sensor, parts)}.
#: An exposure search, the capture and the metrics of one photograph ask for the same parts; the
#: entry holds the image and sensor themselves, so an id is never reused while its entry lives.
_PARTS_CACHE: dict = {}
_PARTS_CACHE_SIZE = 2


def _electrons_parts(si, sensor: Sensor, exposure: Exposure) -> tuple[np.ndarray, np.ndarray]:
    """Electrons per second of continuous light and per full flash, each (rows, cols, 3).

    Read-only arrays, remembered for the last few (image, sensor, lens): do not change a
    SpectralImage's arrays in place after capturing it (make a new image).
    """
    key = (id(si), id(sensor), exposure.lens)
    hit = _PARTS_CACHE.get(key)
    if hit is not None and hit[0] is si and hit[1] is sensor:
        return hit[2]
    parts = _compute_electrons_parts(si, sensor, exposure)
    for a in parts:
        a.flags.writeable = False
    _PARTS_CACHE[key] = (si, sensor, parts)
    while len(_PARTS_CACHE) > _PARTS_CACHE_SIZE:
        _PARTS_CACHE.pop(next(iter(_PARTS_CACHE)))
    return parts


def _compute_electrons_parts(si, sensor: Sensor, exposure: Exposure) -> tuple[np.ndarray, np.ndarray]:
    qe = sensor.qe_at(si.wavelength_nm)
    m = electrons_per_radiance(si.wavelength_nm, si.bandwidth_nm, qe, lens=exposure.lens,
                               pixel_area_m2=sensor.pixel_area_m2, exposure_time_s=1.0)
    rows, cols, nb = np.shape(si.radiance)
    port = port_factor_map(si)  # in-water radiance → radiance in air behind the port, per pixel
    if exposure.lens.vignetting:
        v = vignetting_map(si)
        if v is None:
            log.warning("vignetting asked for but the image has no camera of its own; not applied")
        else:
            port = port * v
    port = np.asarray(port, np.float32)

    def apply(layer):
        if layer is None or not np.any(layer):  # no such light (a strobe-only scene's continuous radiance)
            return np.zeros((rows, cols, 3), np.float32)
        e = (np.asarray(layer).reshape(-1, nb).astype(np.float64) @ m).reshape(rows, cols, 3).astype(np.float32)
        return e * port[..., None] if port.ndim else e * port

    cont, flash = apply(si.radiance), apply(si.layers.get("flash"))
    return cont, flash


def _resampled_mosaic(img: np.ndarray, pattern: str, shape) -> np.ndarray:
    """Mosaic of ``img`` (rows, cols, 3) resampled to ``shape``.

    Downsampling: area average (cv2.INTER_AREA) then mosaic.  Upsampling: each CFA site is
    bilinearly interpolated straight from its channel at its own position (cv2.warpAffine),
    the same values as cv2.resize(INTER_LINEAR) then mosaic, without the full-size RGB.
    """
    import cv2

    rows, cols = int(shape[0]), int(shape[1])
    if (rows, cols) == img.shape[:2]:
        return mosaic(img, pattern)
    if rows < img.shape[0] or cols < img.shape[1]:
        return mosaic(cv2.resize(img, (cols, rows), interpolation=cv2.INTER_AREA), pattern)
    sy, sx = img.shape[0] / rows, img.shape[1] / cols
    out = np.empty((rows, cols), np.float32)
    codes = pattern_codes(pattern)
    for dy in (0, 1):
        for dx in (0, 1):
            h, w = (rows - dy + 1) // 2, (cols - dx + 1) // 2
            m = np.array([[2 * sx, 0, (dx + 0.5) * sx - 0.5], [0, 2 * sy, (dy + 0.5) * sy - 0.5]])
            out[dy::2, dx::2] = cv2.warpAffine(np.ascontiguousarray(img[..., codes[dy, dx]]), m, (w, h),
                                               flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP,
                                               borderMode=cv2.BORDER_REPLICATE)
    return out


def auto_exposure(spectral_image, sensor: Sensor, *, lens: Lens = Lens(), iso: float | None = None,
                  percentile: float = 99.0, target: float = 0.8,
                  temperature_c: float | None = None, flash_shutter_s: float = 1 / 125,
                  mask: np.ndarray | None = None, highlight_clip_pct: float = 0.5) -> Exposure:
    """Exposure that puts the ``percentile`` of the raw signal at ``target`` × saturation.

    Continuous light only: the shutter time is chosen.  With strobes (a ``flash`` layer)
    the shutter stays at ``flash_shutter_s`` (a typical sync speed) and, as a strobe's TTL
    does, the flash output is scaled down (``flash_scale`` ≤ 1); if full power is not enough,
    the ISO is raised (up to the sensor's highest tabulated ISO).  If the continuous light
    alone is too bright at the sync speed, the shutter is shortened and the flash kept off.

    Parameters
    ----------
    percentile
        Percentile (0–100) of the mosaic's mean electrons to place.
    target
        Fraction (0–1] of the saturation electrons (:meth:`Sensor.saturation_e`).
    iso
        ISO to use (default: the sensor's base ISO).
    flash_shutter_s
        Shutter time used with strobes (s).
    mask
        Optional (rows, cols) boolean meter region of the render (a spot meter: e.g. the
        chart); the percentile is taken over its pixels only.
    highlight_clip_pct
        With a spot meter, at most this percentage of the whole frame's pixels may saturate
        (highlight protection, as a camera's metering does): where the region around the spot
        is brighter than the spot — a chart lost in bright backscatter — the exposure is held
        down to it instead of clipping the frame white.
    """
    if not (0 < percentile <= 100) or not (0 < target <= 1):
        raise ConfigError("auto-exposure needs 0 < percentile <= 100 and 0 < target <= 1",
                          field="--auto-exposure")
    iso = sensor.base_iso if iso is None else iso
    probe = Exposure(1.0, iso, lens, temperature_c)
    cont, flash = (mosaic(x, sensor.cfa_pattern) for x in _electrons_parts(spectral_image, sensor, probe))
    frame = None
    if mask is not None and highlight_clip_pct is not None:
        if not 0 <= highlight_clip_pct < 100:
            raise ConfigError(f"highlight_clip_pct must be in [0, 100), got {highlight_clip_pct}",
                              field="--auto-exposure")
        frame = (cont, flash, 100.0 - float(highlight_clip_pct))
    if mask is not None:
        m = np.asarray(mask, bool)
        if m.shape != cont.shape or not m.any():
            raise ConfigError("meter mask must match the render's shape and select pixels", field="mask")
        cont, flash = cont[m], flash[m]
    goal = target * sensor.saturation_e(iso)
    has_flash = "flash" in spectral_image.layers and float(flash.max()) > 0

    def highlights(t, fs):
        """Electrons at the frame's highlight percentile (0 without a spot meter)."""
        if frame is None:
            return 0.0
        fc, ff, q = frame
        return float(np.percentile(fc * t + ff * fs, q))

    def level(t, fs):
        # the spot's percentile, or the frame's highlights scaled so that reaching ``goal``
        # means reaching saturation, whichever comes first
        return max(float(np.percentile(cont * t + flash * fs, percentile)), target * highlights(t, fs))

    if not has_flash or level(flash_shutter_s, 0.0) >= goal:
        lv = level(1.0, 0.0)
        if not np.isfinite(lv) or lv <= 0:
            raise ConfigError("auto-exposure: the image is black", field="--auto-exposure",
                              allowed="a render with light, or a fixed --shutter")
        t = float(np.clip(goal / lv, 1e-6, 3600.0))
        return Exposure(t, iso, lens, temperature_c, flash_scale=0.0 if has_flash else 1.0)
    t = flash_shutter_s
    flash_only = not np.any(cont) and (frame is None or not np.any(frame[0]))

    def ttl(goal):
        """The flash output (≤ 1) that puts :func:`level` at ``goal``: with the flash's light alone the
        level is proportional to it (a percentile of ``flash · fs``), so ``goal / level(t, 1)``;
        otherwise a bisection (the level is monotone in it)."""
        if flash_only:
            return min(goal / level(t, 1.0), 1.0)
        lo, hi = 0.0, 1.0
        for _ in range(40):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if level(t, mid) < goal else (lo, mid)
        return 0.5 * (lo + hi)

    if level(t, 1.0) >= goal:  # TTL
        return Exposure(t, iso, lens, temperature_c, flash_scale=ttl(goal))
    # full power is not enough: raise the ISO (electrons stay, saturation electrons drop)
    lv = level(t, 1.0)
    if lv <= 0:
        raise ConfigError("auto-exposure: the image is black", field="--auto-exposure",
                          allowed="a render with light, or a fixed --shutter")
    hl = highlights(t, 1.0)
    best = iso
    for s_ in sensor.iso_settings:
        if s_.iso < iso:
            continue
        if sensor.saturation_e(s_.iso) < hl:
            break  # this ISO would saturate more of the frame than highlight_clip_pct allows
        best = s_.iso
        if target * sensor.saturation_e(s_.iso) <= lv:
            break
    # ISO steps are a factor ~2 apart: at the chosen ISO full power may overshoot the goal (up to 2x,
    # clipping the frame), so TTL trims the flash to it there
    goal = target * sensor.saturation_e(best)
    if level(t, 1.0) <= goal:
        return Exposure(t, best, lens, temperature_c, flash_scale=1.0)
    return Exposure(t, best, lens, temperature_c, flash_scale=ttl(goal))


def capture(spectral_image, sensor: Sensor, exposure: Exposure, *, seed: int = 0,
            noise: NoiseSwitches = NoiseSwitches(), fpn_seed: int = 0,
            shape: tuple[int, int] | None = None,
            develop: "DevelopOptions | None" = DevelopOptions()) -> Capture:
    """Photograph a SpectralImage with a sensor.

    Parameters
    ----------
    spectral_image
        Radiance at the entrance pupil (:class:`~rigsim.spectral_image.SpectralImage`).
    sensor, exposure
        Camera and settings.
    seed
        Seed of the temporal noise (same seed, same image).
    noise
        Which EMVA 1288 noise terms are on (``NoiseSwitches.off()``: ground truth).
    fpn_seed
        Seed of the fixed-pattern (PRNU/DSNU) maps: one value = one camera body.
    shape
        (rows, cols) of the mosaic; default the render's.  The render is resampled
        (area/bilinear); electrons per pixel follow the sensor's pixel pitch.
    develop
        Development options, or ``None`` for raw only.

    Returns
    -------
    Capture
    """
    t0 = time.perf_counter()
    mean_rgb = mean_electrons_rgb(spectral_image, sensor, exposure)
    mu = _resampled_mosaic(mean_rgb, sensor.cfa_pattern, mean_rgb.shape[:2] if shape is None else shape)
    del mean_rgb
    t1 = time.perf_counter()
    rng = np.random.default_rng(seed)
    temp = sensor.dark_current_ref_temp_c if exposure.temperature_c is None else exposure.temperature_c
    setting = sensor.iso_setting(exposure.iso)
    electrons = electrons_emva1288(mu, sensor, exposure_time_s=exposure.exposure_time_s,
                                   temperature_c=temp, rng=rng, switches=noise, fpn_seed=fpn_seed)
    raw = digitise_emva1288(electrons, gain_dn_per_e=setting.gain_dn_per_e,
                            read_noise_e=setting.read_noise_e, black_level_dn=sensor.black_level_dn,
                            white_level_dn=sensor.white_level_dn, rng=rng, read_noise=noise.read)
    t2 = time.perf_counter()
    cap = Capture(raw=raw, cfa_pattern=sensor.cfa_pattern,
                  black_level=np.full(4, float(sensor.black_level_dn)),
                  white_level=float(sensor.white_level_dn), electrons=electrons, exposure=exposure,
                  sensor=sensor, camera=sensor.name, ccm=ccm_ColorChecker(sensor, "D65"),
                  meta={"seed": seed, "fpn_seed": fpn_seed, "noise": noise.as_dict(),
                        "gain_dn_per_e": setting.gain_dn_per_e, "read_noise_e": setting.read_noise_e,
                        "temperature_c": temp, "render_meta_keys": sorted((spectral_image.meta or {}).keys()),
                        "timing_s": {"optics": t1 - t0, "sensor": t2 - t1}})
    if develop is not None:
        cap = _develop(cap, develop)
    return cap


# ---------------------------------------------------------------- development (ISP)
def _srgb_lut() -> np.ndarray:
    x = np.arange(65536, dtype=np.float64) / 65535.0
    y = np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)
    return np.rint(np.clip(y, 0, 1) * 255).astype(np.uint8)


_SRGB_LUT = None


def encode_srgb8(linear: np.ndarray, *, scratch: np.ndarray | None = None) -> np.ndarray:
    """IEC 61966-2-1 sRGB encoding of linear [0, 1] values to uint8 (through a 16-bit LUT).

    ``scratch``: an optional float32 array of the same shape that may be overwritten.
    """
    global _SRGB_LUT
    if _SRGB_LUT is None:
        _SRGB_LUT = _srgb_lut()
    lin = np.asarray(linear, np.float32)
    ok = scratch is not None and scratch.shape == lin.shape and scratch.dtype == np.float32 \
        and scratch.flags.writeable and scratch.flags.c_contiguous
    idx = np.clip(lin, 0.0, 1.0, out=scratch if ok else None)
    idx *= np.float32(65535.0)
    idx += np.float32(0.5)
    return _SRGB_LUT[idx.astype(np.uint16)]


def _wb_gains(cap: Capture, opts: DevelopOptions) -> np.ndarray:
    method = opts.white_balance
    kw = dict(opts.wb_kwargs)
    if method == "as_shot":
        if cap.as_shot_neutral is None:
            raise ConfigError("this capture has no as-shot white balance", field="--wb",
                              allowed="grayworld, white_patch, chart, illuminant, manual")
        n = np.asarray(cap.as_shot_neutral, float)
        return n[1] / n
    if method == "illuminant":
        if cap.sensor is None:
            raise ConfigError("illuminant white balance needs a simulated sensor's QE", field="--wb",
                              allowed="grayworld, white_patch, chart, manual, as_shot")
        kw.setdefault("sensor", cap.sensor)
        return white_balance_gains(None, method, **kw)
    if method in ("manual",):
        return white_balance_gains(None, method, **kw)
    half = cap.half_rgb()
    if method == "chart":
        if "box" in kw:
            r0, r1, c0, c1 = kw.pop("box")
            kw["box"] = (r0 // 2, max(r1 // 2, r0 // 2 + 1), c0 // 2, max(c1 // 2, c0 // 2 + 1))
        if "mask" in kw:
            m = np.asarray(kw.pop("mask"), bool)
            kw["mask"] = m[: half.shape[0] * 2: 2, : half.shape[1] * 2: 2]
    return white_balance_gains(half, method, **kw)


def _develop(cap: Capture, opts: DevelopOptions) -> Capture:
    t0 = time.perf_counter()
    gains = _wb_gains(cap, opts)  # estimates use a half-size image
    cfa = cap.normalised_mosaic(gains)
    np.clip(cfa, 0.0, 1.0, out=cfa)  # dcraw-style: white-balanced highlights clip to white
    t1 = time.perf_counter()
    rgb = _demosaic(cfa, cap.cfa_pattern, opts.demosaic)
    del cfa
    t2 = time.perf_counter()
    ccm = np.eye(3) if (opts.ccm is None and cap.ccm is None) else np.asarray(
        cap.ccm if opts.ccm is None else opts.ccm, float)
    if ccm.shape != (3, 3):
        raise ConfigError(f"CCM must be 3×3, got {ccm.shape}", field="ccm")
    import cv2

    lin = cv2.transform(np.ascontiguousarray(rgb, np.float32), (ccm * float(opts.gain)).astype(np.float32))
    srgb = encode_srgb8(lin, scratch=rgb)
    del rgb
    t3 = time.perf_counter()
    meta = dict(cap.meta)
    meta["develop"] = opts.describe()
    meta["timing_s"] = {**meta.get("timing_s", {}), "white_balance": t1 - t0, "demosaic": t2 - t1,
                        "ccm_encode": t3 - t2}
    return dataclasses.replace(cap, wb_gains=gains, linear_rgb=lin, srgb=srgb, meta=meta,
                               as_shot_neutral=cap.as_shot_neutral if cap.as_shot_neutral is not None
                               else gains[1] / gains)


def develop(cap: Capture, options: DevelopOptions = DevelopOptions()) -> Capture:
    """Develop a raw Capture (simulated or read from a file): WB → demosaic → CCM → sRGB.

    Steps: (raw − black)/(white − black); white-balance gains applied per CFA site and
    clipped to 1; demosaicing; the CCM (camera → linear sRGB, D65); ×``gain``;
    IEC 61966-2-1 encoding to 8 bits.
    """
    check_pattern(cap.cfa_pattern)
    return _develop(cap, options)
