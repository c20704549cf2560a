"""What an image of a scene is asked to be, checked once for both engines.

:func:`image_request` validates the size, the bands and the ground-truth layers of an image,
and :func:`check_scene_for_bands` that a scene can be imaged in those bands (the water's IOPs
defined at every band centre, every light's and target's spectrum covering every band, the
camera's frame valid).  The Monte Carlo renderer (:func:`rigsim.render.render`) and the fast
engine (:func:`rigsim.preview.render_preview`) both call them, so the same input is accepted
or refused with the same one-line message by either.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from rigsim.errors import ConfigError
from rigsim.scene.types import Scene
from rigsim.spectrum import band_edges

__all__ = ["IMAGE_LAYERS", "MAX_IMAGE_SIDE", "ImageRequest", "image_request", "image_memory_bytes", "check_int",
           "check_scene_for_bands"]

#: Ground-truth layers an image can carry (besides the radiance / flash): see
#: :data:`rigsim.spectral_image.LAYER_DOCS`.
IMAGE_LAYERS = ("range_m", "clear", "object_id", "direct", "backscatter", "particles", "particle_id")
#: Largest image side (pixels).
MAX_IMAGE_SIDE = 16384


def check_int(name: str, v, lo: int, hi: int | None = None) -> int:
    """``v`` as an int in ``[lo, hi]`` (a bool, a fraction or a non-number is refused), else a ConfigError."""
    if isinstance(v, bool):
        raise ConfigError(f"must be an integer, got {v!r}", field=name)
    try:
        iv = int(v)
    except (TypeError, ValueError, OverflowError):
        raise ConfigError(f"must be an integer, got {v!r}", field=name) from None
    if iv != v or iv < lo or (hi is not None and iv > hi):
        raise ConfigError(f"must be an integer in [{lo}, {hi if hi is not None else '∞'}], got {v!r}", field=name,
                          allowed=f"{lo} … {hi if hi is not None else '∞'}")
    return iv


@dataclass(frozen=True, eq=False)
class ImageRequest:
    """A checked image size, bands and ground-truth layers.

    Attributes
    ----------
    width, height
        Pixels.
    wavelength_nm, bandwidth_nm
        Band centres and widths (nm; :func:`rigsim.spectrum.band_edges`).
    layers
        Ground-truth layers from :data:`IMAGE_LAYERS` (``split`` adds ``direct`` and
        ``backscatter``).
    """

    width: int
    height: int
    wavelength_nm: np.ndarray
    bandwidth_nm: np.ndarray
    layers: tuple[str, ...]

    @property
    def band_lo_nm(self) -> float:
        """Lower edge of the first band (nm)."""
        return float(self.wavelength_nm[0] - self.bandwidth_nm[0] / 2)

    @property
    def band_hi_nm(self) -> float:
        """Upper edge of the last band (nm)."""
        return float(self.wavelength_nm[-1] + self.bandwidth_nm[-1] / 2)


#: Spectral layers that come in a continuous and a flash version (besides the radiance itself).
_SPECTRAL_LAYERS = ("clear", "direct", "backscatter")


def image_memory_bytes(width: int, height: int, bands: int, layers: Sequence[str] = ()) -> int:
    """About how much memory an image of this size takes while it is made (bytes).

    Each spectral quantity (radiance and flash, and each of ``clear``, ``direct``,
    ``backscatter`` in both versions) is accumulated in float64 and returned in float32;
    each scalar layer (``range_m``, ``object_id``) takes 8 bytes a pixel.
    """
    spectral = 2 + 2 * sum(1 for k in layers if k in _SPECTRAL_LAYERS)
    scalar = sum(1 for k in layers if k not in _SPECTRAL_LAYERS)
    return int(width) * int(height) * (int(bands) * spectral * (8 + 4) + 8 * scalar)


def image_request(*, width, height, wavelengths_nm, bandwidth_nm=None, layers: Sequence[str] = (),
                  split: bool = False) -> ImageRequest:
    """Check an image's size, bands and layers (one-line ConfigErrors naming the field).

    An image larger than :data:`MAX_IMAGE_SIDE` a side, or one that would not fit in the
    memory available now (:func:`image_memory_bytes`), is refused before anything is
    allocated, with the memory it would need.
    """
    w = check_int("width", width, 1)
    h = check_int("height", height, 1)
    if isinstance(layers, str):
        layers = (layers,)
    layers = tuple(layers)
    for k in layers:
        if k not in IMAGE_LAYERS:
            raise ConfigError(f"unknown layer {k!r}", field="layers", allowed=", ".join(IMAGE_LAYERS))
    if split:
        layers = layers + tuple(k for k in ("direct", "backscatter") if k not in layers)
    wl, bw = band_edges(wavelengths_nm, bandwidth_nm)
    need = image_memory_bytes(w, h, len(wl), layers)
    if w > MAX_IMAGE_SIDE or h > MAX_IMAGE_SIDE:
        from rigsim.resources import format_bytes

        raise ConfigError(f"{w}x{h} pixels is too large: at most {MAX_IMAGE_SIDE} pixels a side (this image would "
                          f"need about {format_bytes(need)} of memory)", field="width" if w > MAX_IMAGE_SIDE
                          else "height", allowed=f"1 … {MAX_IMAGE_SIDE} pixels a side")
    from rigsim.resources import check_memory

    check_memory(need, f"a {w}x{h}-pixel image with {len(wl)} bands and {len(layers)} layers", field="size")
    return ImageRequest(w, h, wl, bw, layers)


def check_scene_for_bands(scene: Scene, request: ImageRequest) -> None:
    """Refuse a scene that cannot be imaged in the request's bands; warn about non-square pixels.

    The water's IOPs must be defined at every band centre (within a band beyond the water's
    table, e.g. 700–705 nm for a table ending at 700 nm, its end value is held); each light's
    and each target's spectrum must cover every band, and reflectances lie in 0–1 (everything
    else about lights, targets and the camera their types check when they are built).
    """
    lo, hi = request.band_lo_nm, request.band_hi_nm
    if scene.water is not None:
        scene.water.check_range([float(request.wavelength_nm[0]), float(request.wavelength_nm[-1])])
    for light in scene.lights:  # kind, table shape and values: checked by Light itself
        wl = np.asarray(light.wavelength_nm, float)
        if wl.size > 1 and (wl[0] > lo + 1e-9 or wl[-1] < hi - 1e-9):
            raise ConfigError(f"light {light.name!r} spectrum covers {wl[0]:g}–{wl[-1]:g} nm, the bands need "
                              f"{lo:g}–{hi:g} nm", field=f"lights.{light.name}",
                              allowed=f"a spectrum covering {lo:g}–{hi:g} nm")
    for i, t in enumerate(scene.targets):  # distance and size: checked by Target itself
        if t.reflectance:
            wl = np.asarray(t.reflectance_wavelength_nm, float)
            r = np.asarray(t.reflectance, float)
            if np.any(~np.isfinite(r)) or np.any(r < 0) or np.any(r > 1):
                raise ConfigError("reflectance must be within 0…1", field=f"targets[{i}].reflectance",
                                  allowed="0 ≤ r ≤ 1")
            if wl.size > 1 and (wl[0] > lo + 1e-9 or wl[-1] < hi - 1e-9):
                raise ConfigError(f"reflectance covers {wl[0]:g}–{wl[-1]:g} nm, the bands need {lo:g}–{hi:g} nm",
                                  field=f"targets[{i}].reflectance")
    w, h = request.width, request.height
    cam = scene.camera
    if abs(w / h - cam.sensor_width_mm / cam.sensor_height_mm) > 0.02 * w / h:
        warnings.warn(f"image aspect {w}x{h} differs from the sensor's {cam.sensor_width_mm}x{cam.sensor_height_mm} mm; "
                      "pixels will not be square", RuntimeWarning, stacklevel=3)
