"""What the optimiser may change on a rig, within which limits, as a vector it can search.

A :class:`Space` is built from a rig document (:class:`~rigsim.config.rigdoc.RigDoc`) and the
limits the user states (the rig file's ``[limits]`` table, :class:`~rigsim.config.rig.LimitsTable`,
then command-line overrides, then :data:`DEFAULT_LIMITS`).  Its parameters are the placement of
the lights as a diver states it, in the rig file's own conventions (camera frame, see
:mod:`rigsim.config.rig`):

*Mirrored pair* (two lights of one kind, one on each side of the lens — the usual twin-strobe rig):
the right light's ``arm_length_m``, ``arm_elevation_deg`` (its arm's angle above the horizontal),
``arm_forward_m``, ``yaw_out_deg`` (turn away from the lens axis, + = outward) and ``pitch_deg``; the
left light is its mirror image about the vertical plane through the lens axis.  Five numbers
whatever the lights' start, so the result is a rig a diver sets up by symmetry.

*Independent* lights (one light, more than two, a pair on one side, or ``symmetric=False``): per
light ``arm_length_m``, ``arm_angle_deg`` (within ``arm_angle_span_deg`` of its own), ``arm_forward_m``,
``yaw_deg``, ``pitch_deg``.

With more than one entry in ``beam_angles_deg`` (e.g. ``[80, 110]``: diffuser off, on) the beam is a
last, discrete parameter shared by the lights (cone beams only; a light with a measured beam profile
keeps it).

The searcher works in the unit cube (:meth:`Space.to_unit`, :meth:`Space.from_unit`);
:meth:`Space.apply` turns a point into a validated rig document, and :meth:`Space.feasible`
refuses placements a diver cannot use: inside the housing (the rig reader's own check) or in the
picture (a light ahead of the pupil inside the field of view in water, with
:data:`LIGHT_HEAD_RADIUS_M` of margin).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from rigsim.config.rig import LimitsTable, world_to_camera
from rigsim.config.rigdoc import RigDoc
from rigsim.errors import ConfigError
from rigsim.schema import validate

__all__ = ["Parameter", "Space", "DEFAULT_LIMITS", "LIGHT_HEAD_RADIUS_M", "SENSITIVITY_STEPS", "limits_for",
           "parse_limits"]

#: Limits used where neither the rig file nor the user states one — the reach of common strobe-arm
#: systems, not a published standard: arms of two or three 5–8 inch (13–20 cm) segments with clamps
#: and the strobe's own mount put a strobe 0.2–0.9 m from the lens axis; the arm can sit from a
#: little ahead of the port to behind the housing; aims within 60° of the lens axis.  Units in the keys.
DEFAULT_LIMITS: dict[str, tuple[float, float] | float] = {
    "arm_length_m": (0.2, 0.9),
    "arm_forward_m": (-0.25, 0.15),
    "arm_elevation_deg": (-45.0, 60.0),
    "arm_angle_span_deg": 60.0,
    "yaw_out_deg": (-20.0, 60.0),
    "yaw_deg": (-60.0, 60.0),
    "pitch_deg": (-30.0, 30.0),
}
#: Radius of a strobe head (m) kept out of the picture: a light ahead of the entrance pupil must sit at
#: least this far outside the in-water field of view (a 10–12 cm strobe face).
LIGHT_HEAD_RADIUS_M = 0.06
#: The step of each parameter a diver can make and feel, for the sensitivities (units of the parameter).
SENSITIVITY_STEPS = {"arm_length_m": 0.1, "arm_elevation_deg": 15.0, "arm_angle_deg": 15.0,
                     "arm_forward_m": 0.1, "yaw_out_deg": 10.0, "yaw_deg": 10.0, "pitch_deg": 10.0}

_LABELS = {"arm_length_m": "arm length", "arm_elevation_deg": "arm elevation", "arm_angle_deg": "arm angle",
           "arm_forward_m": "forward offset", "yaw_out_deg": "turned outward", "yaw_deg": "yaw",
           "pitch_deg": "pitch", "beam_angle_deg": "beam angle"}


@dataclass(frozen=True)
class Parameter:
    """One searched number.

    Attributes
    ----------
    key
        Its name in the rig file's conventions (``arm_length_m``, ``yaw_out_deg`` …; unit in the name).
    light
        The light it belongs to (None: the mirrored pair, or the shared beam).
    lo, hi
        Limits (unit of ``key``); ``lo == hi`` fixes it.
    options
        For the discrete beam: the angles (deg) it chooses among.
    """

    key: str
    light: int | None
    lo: float
    hi: float
    options: tuple[float, ...] = ()

    @property
    def label(self) -> str:
        name = _LABELS.get(self.key, self.key)
        return name if self.light is None else f"{name} ({self.light})"

    @property
    def unit(self) -> str:
        return "m" if self.key.endswith("_m") else "deg"

    def clip(self, v: float) -> float:
        return float(min(max(v, self.lo), self.hi))


def parse_limits(text: str | None) -> dict:
    """``"arm_length_m=0.3:0.8,yaw_out_deg=0:40,beam_angles_deg=80/110"`` → a limits dict, validated by
    :class:`~rigsim.config.rig.LimitsTable` (one-line :class:`ConfigError` naming ``--limits`` and the key)."""
    out: dict = {}
    if not text:
        return out
    for part in str(text).split(","):
        if not part.strip():
            continue
        key, eq, val = part.partition("=")
        key = key.strip()
        if not eq:
            raise ConfigError(f"{part!r} is not key=value", field="--limits",
                              allowed="key=low:high, e.g. arm_length_m=0.3:0.8; beam_angles_deg=80/110")
        try:
            if key == "beam_angles_deg":
                out[key] = [float(x) for x in val.split("/")]
            elif key == "arm_angle_span_deg":
                out[key] = float(val)
            else:
                lo, colon, hi = val.partition(":")
                out[key] = [float(lo), float(hi)] if colon else [float(lo), float(lo)]
        except ValueError:
            raise ConfigError(f"{val!r} is not a number range", field=f"--limits {key}",
                              allowed="low:high in the key's unit") from None
    validate(LimitsTable, out, file="--limits")
    return out


def limits_for(doc: RigDoc, overrides: dict | None = None) -> dict:
    """The limits in force: :data:`DEFAULT_LIMITS`, then the rig file's ``[limits]``, then ``overrides``
    (already validated, e.g. from :func:`parse_limits`); ``beam_angles_deg`` defaults to none (the
    lights keep their beams)."""
    stated = validate(LimitsTable, doc.data.get("limits", {}), file=doc.source, prefix="limits").stated()
    out = dict(DEFAULT_LIMITS)
    out.update(stated)
    out.update({k: (tuple(v) if isinstance(v, list) else v) for k, v in (overrides or {}).items()})
    return out


def _mirrored_pair(doc: RigDoc) -> tuple[int, int] | None:
    """(right, left) indices if the rig has exactly two lights of one kind on opposite sides of the lens."""
    n = len(doc.data.get("lights", []))
    if n != 2:
        return None
    views = [doc.light_view(i) for i in range(2)]
    if views[0]["kind"] != views[1]["kind"]:
        return None
    x = [math.cos(math.radians(v["arm_angle_deg"])) for v in views]
    if x[0] * x[1] >= 0:
        return None
    return (0, 1) if x[0] > 0 else (1, 0)


@dataclass(frozen=True)
class Space:
    """The searched placement of a rig's lights (see the module docstring).

    Build with :meth:`of`.
    """

    doc: RigDoc
    parameters: tuple[Parameter, ...]
    pair: tuple[int, int] | None
    limits: dict = field(default_factory=dict)

    # ------------------------------------------------------------------ construction
    @classmethod
    def of(cls, doc: RigDoc, *, limits: dict | None = None, symmetric: bool | None = None) -> "Space":
        """The space of ``doc``'s lights within ``limits`` (:func:`limits_for`'s result; None: that of
        ``doc`` alone); ``symmetric`` None = mirrored when the rig is a pair (:func:`_mirrored_pair`).

        Raises
        ------
        ConfigError
            A rig without lights, or ``symmetric=True`` for a rig that is not a pair.
        """
        lim = limits_for(doc) if limits is None else limits
        n = len(doc.data.get("lights", []))
        if n == 0:
            raise ConfigError("the rig has no lights to place", file=doc.source, field="lights",
                              allowed="at least one [[lights]] table")
        pair = _mirrored_pair(doc)
        if symmetric is True and pair is None:
            raise ConfigError("a mirrored search needs two lights of one kind, one each side of the lens",
                              file=doc.source, field="lights", allowed="--independent for this rig")
        if symmetric is False:
            pair = None
        params: list[Parameter] = []
        if pair is not None:
            for key in ("arm_length_m", "arm_elevation_deg", "arm_forward_m", "yaw_out_deg", "pitch_deg"):
                lo, hi = lim[key]
                params.append(Parameter(key, None, float(lo), float(hi)))
        else:
            span = float(lim["arm_angle_span_deg"])
            for i in range(n):
                own = doc.light_view(i)["arm_angle_deg"]
                for key in ("arm_length_m", "arm_angle_deg", "arm_forward_m", "yaw_deg", "pitch_deg"):
                    lo, hi = (own - span, own + span) if key == "arm_angle_deg" else lim[key]
                    params.append(Parameter(key, i, float(lo), float(hi)))
        beams = tuple(lim.get("beam_angles_deg") or ())
        cones = [i for i in range(n) if doc.light_view(i)["beam_mode"] == "cone"]
        if len(beams) > 1 and cones:
            params.append(Parameter("beam_angle_deg", None, 0.0, float(len(beams) - 1), options=beams))
        return cls(doc=doc, parameters=tuple(params), pair=pair, limits=lim)

    # ------------------------------------------------------------------ vectors
    @property
    def dim(self) -> int:
        return len(self.parameters)

    @property
    def beam(self) -> Parameter | None:
        return next((p for p in self.parameters if p.options), None)

    def to_unit(self, x: np.ndarray) -> np.ndarray:
        lo, hi = self._bounds()
        return np.where(hi > lo, (np.asarray(x, float) - lo) / np.where(hi > lo, hi - lo, 1.0), 0.5)

    def from_unit(self, u: np.ndarray) -> np.ndarray:
        lo, hi = self._bounds()
        x = lo + np.clip(np.asarray(u, float), 0.0, 1.0) * (hi - lo)
        b = self.beam
        if b is not None:
            x[-1] = float(np.clip(np.round(x[-1]), 0, len(b.options) - 1))
        return x

    def _bounds(self) -> tuple[np.ndarray, np.ndarray]:
        return (np.array([p.lo for p in self.parameters]), np.array([p.hi for p in self.parameters]))

    def start(self) -> np.ndarray:
        """The rig's own placement as a point (clipped into the limits; for a mirrored pair the mean of
        the right light and the left one's mirror image)."""
        x = []
        for p in self.parameters:
            if p.options:
                angles = [self.doc.light_view(i)["beam_angle_deg"] for i in range(len(self.doc.data["lights"]))]
                x.append(float(np.argmin(np.abs(np.array(p.options) - np.mean(angles)))))
                continue
            x.append(p.clip(self._start_value(p)))
        return np.array(x, float)

    def _start_value(self, p: Parameter, doc: RigDoc | None = None) -> float:
        doc = self.doc if doc is None else doc
        if self.pair is None:
            return float(doc.light_view(p.light)[p.key])
        r, l_ = (doc.light_view(i) for i in self.pair)
        a_r = (r["arm_angle_deg"] + 180.0) % 360.0 - 180.0          # right arm: angle above horizontal
        a_l = (180.0 - l_["arm_angle_deg"] + 180.0) % 360.0 - 180.0  # left arm, mirrored
        return {"arm_length_m": 0.5 * (r["arm_length_m"] + l_["arm_length_m"]),
                "arm_elevation_deg": 0.5 * (a_r + a_l),
                "arm_forward_m": 0.5 * (r["arm_forward_m"] + l_["arm_forward_m"]),
                "yaw_out_deg": 0.5 * (r["yaw_deg"] - l_["yaw_deg"]),
                "pitch_deg": 0.5 * (r["pitch_deg"] + l_["pitch_deg"])}[p.key]

    # ------------------------------------------------------------------ rigs
    def placements(self, x: np.ndarray) -> dict[int, dict]:
        """Light index → the rig-file keys of point ``x`` (see :meth:`RigDoc.place_lights`)."""
        x = np.asarray(x, float)
        vals = {(p.key, p.light): float(v) for p, v in zip(self.parameters, x)}
        b = self.beam
        beam = {} if b is None else {"beam_angle_deg": b.options[int(round(vals[(b.key, None)]))]}
        n = len(self.doc.data["lights"])
        out: dict[int, dict] = {}
        if self.pair is not None:
            r, l_ = self.pair
            g = {k: vals[(k, None)] for k in ("arm_length_m", "arm_elevation_deg", "arm_forward_m", "yaw_out_deg",
                                             "pitch_deg")}
            common = {"arm_length_m": g["arm_length_m"], "arm_forward_m": g["arm_forward_m"],
                      "pitch_deg": g["pitch_deg"]}
            out[r] = {**common, "arm_angle_deg": g["arm_elevation_deg"], "yaw_deg": g["yaw_out_deg"]}
            out[l_] = {**common, "arm_angle_deg": 180.0 - g["arm_elevation_deg"], "yaw_deg": -g["yaw_out_deg"]}
        else:
            for i in range(n):
                out[i] = {k: vals[(k, i)] for k in ("arm_length_m", "arm_angle_deg", "arm_forward_m", "yaw_deg",
                                                    "pitch_deg")}
        for i in out:
            if beam and self.doc.light_view(i)["beam_mode"] == "cone":
                out[i].update(beam)
        return out

    def apply(self, x: np.ndarray) -> RigDoc:
        """The rig document of point ``x`` (validated; raises :class:`ConfigError` if the rig reader refuses it)."""
        return self.doc.place_lights(self.placements(x))

    def feasible(self, doc: RigDoc) -> str | None:
        """None if a diver can use ``doc``'s placement, else why not (one phrase)."""
        from rigsim.scene.optics import fov_water_deg

        rig = doc.rig()
        cam = rig.camera
        half_w = math.radians(fov_water_deg(cam)) / 2
        half_h = math.atan(math.tan(half_w) * cam.sensor_height_mm / cam.sensor_width_mm)
        for light in rig.lights:
            x, y, z = (float(v) for v in world_to_camera(cam, light.position_m))
            if z <= 0:
                continue
            # outside the view if beyond the frustum's side by more than the head's radius
            out_x = abs(x) - z * math.tan(half_w) > LIGHT_HEAD_RADIUS_M / math.cos(half_w)
            out_y = abs(y) - z * math.tan(half_h) > LIGHT_HEAD_RADIUS_M / math.cos(half_h)
            if not (out_x or out_y):
                return f"{light.name} would be in the picture"
        return None

    def describe_doc(self, doc: RigDoc) -> dict[str, float]:
        """:meth:`describe` of a rig document's own placement (not clipped to the limits; a mirrored pair
        that is not quite mirrored as the mean of the right light and the left one's mirror image; the beam
        as the lights' mean beam angle)."""
        out = {}
        for p in self.parameters:
            if p.options:
                angles = [doc.light_view(i)["beam_angle_deg"] for i in range(len(doc.data["lights"]))]
                out[p.label] = round(float(np.mean(angles)), 1)
            else:
                out[p.label] = round(self._start_value(p, doc), 3 if p.unit == "m" else 1)
        return out

    def describe(self, x: np.ndarray) -> dict[str, float]:
        """Parameter label → value (the beam as its angle, deg)."""
        out = {}
        for p, v in zip(self.parameters, np.asarray(x, float)):
            out[p.label] = p.options[int(round(v))] if p.options else round(float(v), 3 if p.unit == "m" else 1)
        return out
