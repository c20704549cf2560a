"""Take the photograph of a rendered scene: expose, capture and develop, with one set of fallbacks.

The rig designer (:mod:`rigsim.ui.predict`) and the studies (:mod:`rigsim.study.case`)
both turn a :class:`~rigsim.spectral_image.SpectralImage` into a developed photograph
through :func:`photograph`, so a study row and the designer's preview of the same
case are developed alike.

Rules (the same for every caller):

Exposure
    ``"auto"``: :func:`~rigsim.sensor.pipeline.auto_exposure`.  For a ColorChecker
    target (``target_kind == "colorchecker"``) the meter is a spot meter on the chart
    (the ``"target"`` mask of :func:`rigsim.metrics.scene.target_masks`), so its white
    patch lands at ``target_level``; for other targets, or without that mask, the whole
    frame is metered.  The ISO is ``iso``; None, or an ISO below the sensor's base
    ISO, means the base ISO.  An :class:`~rigsim.sensor.pipeline.Exposure` is used as
    given (manual).
White balance
    ``"auto"``: on the chart's ``neutral 5`` patch (method ``"chart"``) when the image
    has that patch with at least 4 pixels; otherwise gray world.  If the chart white
    balance is refused (the patch is clipped or lost in the water's light: a
    :class:`~rigsim.errors.ConfigError`), gray world.  Any other name is used as is and
    its errors propagate.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rigsim.errors import ConfigError
from rigsim.sensor.model import Sensor
from rigsim.sensor.optics import lens_for
from rigsim.sensor.pipeline import Capture, DevelopOptions, Exposure, auto_exposure, capture

__all__ = ["Photograph", "photograph", "AUTO_WB_PATCH", "AUTO_WB_MIN_PIXELS"]

#: The mask key (prefix) of the patch ``"auto"`` white balance uses.
AUTO_WB_PATCH = "patch:neutral 5"
#: Fewest pixels of that patch for a chart white balance.
AUTO_WB_MIN_PIXELS = 4


@dataclass(frozen=True, eq=False)
class Photograph:
    """A developed capture and the choices that made it.

    Attributes
    ----------
    capture
        The :class:`~rigsim.sensor.pipeline.Capture` (raw, linear sRGB, 8-bit sRGB).
    exposure
        The exposure used (chosen by the meter for ``"auto"``).
    white_balance
        The white-balance method used (``"chart"``, ``"grayworld"``, …).
    metered
        ``"spot"`` (the chart), ``"frame"`` or ``"manual"``.
    """

    capture: Capture
    exposure: Exposure
    white_balance: str
    metered: str


def _auto_white_balance(masks: dict) -> tuple[str, dict]:
    patch = next((k for k in masks if k.startswith(AUTO_WB_PATCH)), None)
    if patch is not None and int(np.sum(masks[patch])) >= AUTO_WB_MIN_PIXELS:
        return "chart", {"mask": masks[patch]}
    return "grayworld", {}


def photograph(spectral_image, sensor: Sensor, *, f_number: float | None = None, exposure: str | Exposure = "auto",
               white_balance: str = "auto", masks: dict | None = None, target_kind: str = "",
               iso: float | None = None, percentile: float = 99.0, target_level: float = 0.8,
               demosaic: str = DevelopOptions.demosaic, seed: int = 0) -> Photograph:
    """Expose, capture and develop ``spectral_image`` with ``sensor`` (see the module rules).

    Parameters
    ----------
    spectral_image
        The render (:class:`~rigsim.spectral_image.SpectralImage`).
    sensor
        The camera sensor.
    f_number
        The lens aperture for ``"auto"`` exposure (None: the image's own camera,
        :func:`~rigsim.sensor.optics.lens_for`); a given :class:`Exposure` has its own lens.
    exposure
        ``"auto"`` or an :class:`~rigsim.sensor.pipeline.Exposure`.
    white_balance
        ``"auto"`` or a name of :data:`~rigsim.sensor.white_balance.WHITE_BALANCE_METHODS`.
    masks
        Target masks of the render (:func:`rigsim.metrics.scene.target_masks`), for the spot
        meter and the chart white balance.
    target_kind
        The target's kind (``"colorchecker"`` selects the spot meter).
    iso, percentile, target_level
        Auto exposure: ISO (None: base ISO), and the percentile of the raw signal placed at
        ``target_level`` × saturation.
    demosaic
        Demosaicing method.
    seed
        Noise seed of the capture.

    Raises
    ------
    ConfigError
        Unknown exposure mode or white balance, impossible auto exposure.
    """
    masks = masks or {}
    if isinstance(exposure, Exposure):
        ex, metered = exposure, "manual"
    elif exposure == "auto":
        meter = masks.get("target") if target_kind == "colorchecker" else None
        metered = "spot" if meter is not None else "frame"
        ex = auto_exposure(spectral_image, sensor, lens=lens_for(spectral_image, f_number=f_number),
                           iso=iso if iso is not None and iso >= sensor.base_iso else None,
                           percentile=percentile, target=target_level, mask=meter)
    else:
        raise ConfigError(f"unknown exposure {exposure!r}", field="exposure",
                          allowed="auto, or an Exposure (manual)")
    auto = white_balance == "auto"
    wb, wb_kw = _auto_white_balance(masks) if auto else (white_balance, {})

    def shoot(wb: str, wb_kw: dict) -> Capture:
        return capture(spectral_image, sensor, ex, seed=seed,
                       develop=DevelopOptions(demosaic=demosaic, white_balance=wb, wb_kwargs=wb_kw))

    try:
        cap = shoot(wb, wb_kw)
    except ConfigError:
        if not (auto and wb == "chart"):
            raise
        wb, wb_kw = "grayworld", {}  # the neutral patch is clipped or lost in the water's light
        cap = shoot(wb, wb_kw)
    return Photograph(capture=cap, exposure=ex, white_balance=wb, metered=metered)
