"""A rig file as an editable document.

The designer edits a rig the way a diver thinks about it — arm length and angle,
yaw and pitch, beam angle, power — while the document keeps the rig file's own
table (as read by :func:`rigsim.schema.read_toml`).  Each edit rewrites the
light's keys in one of the forms ``rigs/README.md`` allows (the *arm convention* for
positions, ``yaw_deg`` / ``pitch_deg`` or ``aim_at_m`` for aims), is validated by
:func:`rigsim.config.rig.parse_rig` (so the app and the CLI accept exactly the same
rigs) and is refused with that function's one-line message if it is invalid.
Untouched keys — comments aside — survive a load/save round trip.

The file's conventions (arm, yaw/pitch, default spectra, spectrum names) and their
inverses come from :mod:`rigsim.config.rig`, the one implementation.

:func:`dumps_toml` writes the table back as TOML in the layout of the shipped
rigs (``[rig]``, ``[camera]``, ``[port]``, ``[[lights]]``).

Examples
--------
>>> from pathlib import Path
>>> doc = RigDoc.load(Path(__file__).parents[2] / "rigs" / "twin-strobes-45-wide.toml")
>>> round(doc.light_view(0)["arm_length_m"], 3)
0.45
>>> doc2 = doc.edit_light(0, "arm_length_m", 0.6)
>>> round(doc2.rig().lights[0].position_m[0], 3)   # image left is world +x
0.58
>>> doc.edit_light(0, "arm_length_m", 0.05)
Traceback (most recent call last):
...
rigsim.errors.ConfigError: twin-strobes-45-wide.toml: lights[0].arm_length_m: light is inside the housing: ...
"""

from __future__ import annotations

import copy
import json
import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from rigsim.config.rig import (
    DEFAULT_SPECTRUM,
    SPECTRUM_NAMES,
    LightTable,
    direction_to_yaw_pitch,
    parse_rig,
    position_to_arm,
)
from rigsim.schema import read_toml, toml_from_text, validate
from rigsim.errors import ConfigError
from rigsim.scene.types import Rig

__all__ = ["RigDoc", "dumps_toml", "parse_number", "LIGHT_FIELDS", "CAMERA_FIELDS", "SPECTRA"]

#: Named spectra a light may use (``blackbody:T`` and CSV files are accepted too).
SPECTRA = SPECTRUM_NAMES

#: Light fields the designer edits, with the keys each one replaces in the file.
LIGHT_FIELDS = {
    "name": (),
    "arm_length_m": ("position_m",), "arm_angle_deg": ("position_m",), "arm_forward_m": ("position_m",),
    "yaw_deg": ("aim", "aim_at_m"), "pitch_deg": ("aim", "aim_at_m"),
    "aim_at_m": ("aim", "yaw_deg", "pitch_deg"),
    "beam_angle_deg": ("beam_profile",), "beam_edge_exponent": ("beam_profile",),
    "spectrum": (),
    "guide_number_m": ("flash_energy_J", "luminous_efficacy_lm_s_per_J"),
    "flash_energy_J": ("guide_number_m", "guide_number_iso"),
    "power_fraction": (), "lumens": (),
}
#: Camera and port fields the designer edits: field → (table, key, keys it replaces).
CAMERA_FIELDS = {
    "focal_length_mm": ("camera", "focal_length_mm", ("fov_deg",)),
    "f_number": ("camera", "f_number", ()),
    "focus_distance_m": ("camera", "focus_distance_m", ()),
    "housing_radius_m": ("camera", "housing_radius_m", ()),
    "port_kind": ("port", "kind", ()),
    "port_radius_m": ("port", "radius_m", ()),
    "rig_name": ("rig", "name", ()),
    "rig_description": ("rig", "description", ()),
}
_STRING_FIELDS = {"name", "spectrum", "port_kind", "rig_name", "rig_description"}
_TABLE_ORDER = ("rig", "camera", "port", "lights")


def parse_number(value: Any, field: str) -> float:
    """A finite number from a UI value (number or text), else a one-line :class:`ConfigError`."""
    if isinstance(value, bool):
        raise ConfigError(f"must be a number, got {value!r}", field=field)
    if isinstance(value, (int, float)):
        v = float(value)
    else:
        text = str(value).strip().replace(",", ".")
        try:
            v = float(text)
        except ValueError:
            raise ConfigError(f"must be a number, got {str(value)!r}", field=field) from None
    if not math.isfinite(v):
        raise ConfigError(f"must be a finite number, got {value!r}", field=field)
    return v


def _clean(x: float, nd: int = 6) -> float:
    """Round away float noise from UI arithmetic (0.30000000000000004 → 0.3)."""
    v = round(float(x), nd)
    return 0.0 if v == 0 else v


@dataclass(frozen=True)
class RigDoc:
    """A rig file's table plus where it came from.

    Attributes
    ----------
    data
        The TOML table (``rig``, ``camera``, ``port``, ``lights``), as :func:`~rigsim.schema.read_toml` reads it.
    source
        What error messages name (the file name, or ``<edited rig>``).
    base_dir
        Folder that relative CSV paths (spectra, beam profiles) resolve against.
    """

    data: dict
    source: str = "<edited rig>"
    base_dir: Path = field(default_factory=Path.cwd)

    # ------------------------------------------------------------------ I/O
    @classmethod
    def load(cls, path: str | Path) -> "RigDoc":
        """Read and validate a rig file (raises :class:`ConfigError` with one line)."""
        p = Path(path)
        doc = cls(read_toml(p), source=p.name, base_dir=p.resolve().parent)
        doc.rig()
        return doc

    @classmethod
    def loads(cls, text: str, *, source: str = "<edited rig>", base_dir: Path | None = None) -> "RigDoc":
        doc = cls(toml_from_text(text, source=source), source=source, base_dir=base_dir or Path.cwd())
        doc.rig()
        return doc

    def rig(self) -> Rig:
        """The validated :class:`Rig` (raises :class:`ConfigError`)."""
        return parse_rig(self.data, source=self.source, base_dir=self.base_dir)

    def to_toml(self, *, header: str | None = None) -> str:
        """The rig file's text (see :func:`dumps_toml`)."""
        return dumps_toml(self.data, header=header)

    def relocated(self, folder: Path, source: str) -> "RigDoc":
        """The same rig to be saved in ``folder``: relative CSV paths are rewritten to still point
        at the same files."""
        data = copy.deepcopy(self.data)
        folder = Path(folder).resolve()
        for t in data.get("lights", []):
            for key in ("beam_profile", "spectrum"):
                v = t.get(key)
                if isinstance(v, str) and v.lower().endswith(".csv") and not Path(v).is_absolute():
                    t[key] = os.path.relpath((self.base_dir / v).resolve(), folder)
        return RigDoc(data, source=source, base_dir=folder)

    # ------------------------------------------------------------------ views
    @property
    def name(self) -> str:
        return str(self.data.get("rig", {}).get("name", Path(self.source).stem))

    def light_table(self, index: int) -> LightTable:
        """Light ``index`` as the rig file's schema reads it (:class:`~rigsim.config.rig.LightTable`)."""
        return validate(LightTable, self.data["lights"][index], file=self.source, prefix=f"lights[{index}]")

    def light_names(self) -> list[str]:
        return [str(t.get("name", f"light{i}")) for i, t in enumerate(self.data.get("lights", []))]

    def light_view(self, index: int) -> dict:
        """The designer's view of light ``index`` (camera frame ``[right, up, forward]``).

        Keys: ``name``, ``kind``, ``arm_length_m``, ``arm_angle_deg`` (0–360),
        ``arm_forward_m``, ``aim_mode`` (``angles`` or ``point``), ``yaw_deg``, ``pitch_deg``,
        ``aim_at_m``, ``beam_mode`` (``cone`` or ``profile``), ``beam_angle_deg``,
        ``beam_profile``, ``spectrum``, ``power_mode`` (``guide_number``, ``energy`` or
        ``lumens``), ``guide_number_m``, ``flash_energy_J``, ``power_fraction``, ``lumens``.
        """
        t = self.data["lights"][index]
        lt = self.light_table(index)
        arm_length, arm_angle, arm_forward = position_to_arm(lt.local_position())
        yaw, pitch = direction_to_yaw_pitch(lt.local_aim())
        kind = lt.kind
        if kind == "video":
            power_mode = "lumens"
        else:
            power_mode = "energy" if "flash_energy_J" in t else "guide_number"
        aim_at = t.get("aim_at_m")
        if aim_at is None:  # where the axis crosses the focus plane (or 1.5 m) — a sensible start
            reach = float(self.data.get("camera", {}).get("focus_distance_m", 1.5))
            aim_at = [0.0, 0.0, reach]
        return {
            "name": str(t.get("name", f"light{index}")), "kind": kind,
            "arm_length_m": _clean(arm_length, 4),
            "arm_angle_deg": _clean(arm_angle, 3) % 360.0,
            "arm_forward_m": _clean(arm_forward, 4),
            "aim_mode": "point" if "aim_at_m" in t else "angles",
            "yaw_deg": _clean(yaw, 3), "pitch_deg": _clean(pitch, 3),
            "aim_at_m": [_clean(x, 4) for x in aim_at],
            "beam_mode": "profile" if "beam_profile" in t else "cone",
            "beam_angle_deg": float(t.get("beam_angle_deg", 100.0)),
            "beam_edge_exponent": float(t.get("beam_edge_exponent", 2.0)),
            "beam_profile": str(t.get("beam_profile", "")),
            "spectrum": lt.spectrum_name,
            "power_mode": power_mode,
            "guide_number_m": float(t.get("guide_number_m", 24.0)),
            "flash_energy_J": float(t.get("flash_energy_J", 50.0)),
            "power_fraction": float(t.get("power_fraction", 1.0)),
            "lumens": float(t.get("lumens", 3000.0)),
        }

    def camera_view(self) -> dict:
        """The designer's view of the camera and port (rig name, lens, port)."""
        rig = self.rig()
        cam = self.data.get("camera", {})
        port = self.data.get("port", {})
        return {"rig_name": self.name, "rig_description": str(self.data.get("rig", {}).get("description", "")),
                "focal_length_mm": _clean(rig.camera.focal_length_mm, 3), "f_number": rig.camera.f_number,
                "focus_distance_m": cam.get("focus_distance_m"), "housing_radius_m": rig.camera.housing_radius_m,
                "port_kind": str(port.get("kind", "dome")), "port_radius_m": rig.camera.port.radius_m}

    # ------------------------------------------------------------------ edits
    def _validated(self, data: dict) -> "RigDoc":
        doc = RigDoc(data, source=self.source, base_dir=self.base_dir)
        doc.rig()
        return doc

    def edit_light(self, index: int, field_name: str, value: Any) -> "RigDoc":
        """A new document with one light field changed, validated (raises :class:`ConfigError`).

        Position fields rewrite the light in the arm convention, ``yaw_deg``/``pitch_deg``
        replace any ``aim``/``aim_at_m``, ``aim_at_m`` replaces angles, and so on
        (:data:`LIGHT_FIELDS`).
        """
        if field_name not in LIGHT_FIELDS:
            raise ConfigError(f"not an editable light field: {field_name!r}", field=field_name,
                              allowed=", ".join(LIGHT_FIELDS))
        lights = self.data.get("lights", [])
        if not 0 <= index < len(lights):
            raise ConfigError(f"no light number {index}", field="lights")
        where = f"lights[{index}].{field_name}"
        if field_name in _STRING_FIELDS:
            v: Any = str(value).strip()
            if not v:
                raise ConfigError("must not be empty", field=where)
        elif field_name == "aim_at_m":
            if not isinstance(value, (list, tuple)) or len(value) != 3:
                raise ConfigError("must be 3 numbers [right, up, forward] in m", field=where)
            v = [_clean(parse_number(x, where)) for x in value]
        else:
            v = _clean(parse_number(value, where))
        data = copy.deepcopy(self.data)
        t = data["lights"][index]
        view = self.light_view(index)
        if field_name in ("arm_length_m", "arm_angle_deg", "arm_forward_m"):
            arm = {k: view[k] for k in ("arm_length_m", "arm_angle_deg", "arm_forward_m")}
            arm[field_name] = v
            t.pop("position_m", None)
            t.update(arm)
        elif field_name in ("yaw_deg", "pitch_deg"):
            angles = {"yaw_deg": view["yaw_deg"], "pitch_deg": view["pitch_deg"]}
            angles[field_name] = v
            t.pop("aim", None)
            t.pop("aim_at_m", None)
            t.update(angles)
        else:
            t[field_name] = v
        for key in LIGHT_FIELDS[field_name]:
            t.pop(key, None)
        return self._validated(data)

    def move_light(self, index: int, position_m) -> "RigDoc":
        """A new document with light ``index`` at ``position_m`` (camera frame ``[right, up,
        forward]``, m), written in the arm convention (mm, 0.01°), validated.

        The aim is kept as the file states it: angles stay angles (the same direction), an aim
        point stays the point (the light turns to keep it in its beam), as a diver moving a
        strobe on its arm would expect.
        """
        p = np.asarray(position_m, float).ravel()
        where = f"lights[{index}].position_m"
        if p.shape != (3,) or not np.all(np.isfinite(p)):
            raise ConfigError("must be 3 finite numbers [right, up, forward] in m", field=where)
        lights = self.data.get("lights", [])
        if not 0 <= index < len(lights):
            raise ConfigError(f"no light number {index}", field="lights")
        data = copy.deepcopy(self.data)
        t = data["lights"][index]
        if "aim" not in t and "aim_at_m" not in t:  # angles: keep the direction the light had
            yaw, pitch = direction_to_yaw_pitch(self.light_table(index).local_aim())
            t["yaw_deg"], t["pitch_deg"] = _clean(yaw, 3), _clean(pitch, 3)
        for key in ("position_m", "arm_length_m", "arm_angle_deg", "arm_forward_m"):
            t.pop(key, None)
        length, angle, forward = position_to_arm(p)
        t["arm_length_m"] = _clean(length, 3)
        t["arm_angle_deg"] = _clean(angle, 2) % 360.0
        t["arm_forward_m"] = _clean(forward, 3)
        return self._validated(data)

    def place_lights(self, placements: dict[int, dict]) -> "RigDoc":
        """A new document with lights moved, validated once (the optimiser's move).

        ``placements`` maps a light's index to its new ``arm_length_m``, ``arm_angle_deg``,
        ``arm_forward_m``, ``yaw_deg``, ``pitch_deg`` (all required) and optionally
        ``beam_angle_deg`` (a cone beam replacing any profile); they are written as the file's arm and
        angle keys (mm, 0.01°).  Raises :class:`ConfigError` like any edit (a light inside the housing …).
        """
        lights = self.data.get("lights", [])
        data = copy.deepcopy(self.data)
        for index, p in placements.items():
            if not 0 <= index < len(lights):
                raise ConfigError(f"no light number {index}", field="lights")
            t = data["lights"][index]
            for key in ("position_m", "aim", "aim_at_m"):
                t.pop(key, None)
            for key, nd in (("arm_length_m", 3), ("arm_angle_deg", 2), ("arm_forward_m", 3), ("yaw_deg", 2),
                            ("pitch_deg", 2), ("beam_angle_deg", 2)):
                if key not in p:
                    if key == "beam_angle_deg":
                        continue
                    raise ConfigError("missing from the placement", field=f"lights[{index}].{key}")
                t[key] = _clean(parse_number(p[key], f"lights[{index}].{key}"), nd)
            t["arm_angle_deg"] %= 360.0
            if "beam_angle_deg" in p:
                t.pop("beam_profile", None)
        return self._validated(data)

    def set_aim_mode(self, index: int, mode: str) -> "RigDoc":
        """Switch light ``index`` between aiming by ``angles`` (yaw/pitch) and at a ``point``."""
        view = self.light_view(index)
        if mode == "point":
            return self.edit_light(index, "aim_at_m", view["aim_at_m"])
        if mode == "angles":
            return self.edit_light(index, "yaw_deg", view["yaw_deg"])
        raise ConfigError(f"unknown aim mode {mode!r}", field=f"lights[{index}].aim", allowed="angles, point")

    def set_power_mode(self, index: int, mode: str) -> "RigDoc":
        """Rate a strobe by ``guide_number`` (m, in air) or stored ``energy`` (J)."""
        view = self.light_view(index)
        if mode == "guide_number":
            return self.edit_light(index, "guide_number_m", view["guide_number_m"])
        if mode == "energy":
            return self.edit_light(index, "flash_energy_J", view["flash_energy_J"])
        raise ConfigError(f"unknown power mode {mode!r}", field=f"lights[{index}].power",
                          allowed="guide_number, energy")

    def edit_camera(self, field_name: str, value: Any) -> "RigDoc":
        """A new document with one camera/port/rig field changed, validated."""
        if field_name not in CAMERA_FIELDS:
            raise ConfigError(f"not an editable camera field: {field_name!r}", field=field_name,
                              allowed=", ".join(CAMERA_FIELDS))
        table, key, replaces = CAMERA_FIELDS[field_name]
        where = f"{table}.{key}"
        if field_name in _STRING_FIELDS:
            v: Any = str(value).strip()
            if field_name != "rig_description" and not v:
                raise ConfigError("must not be empty", field=where)
        elif field_name == "focus_distance_m" and (value is None or str(value).strip() == ""):
            v = None
        else:
            v = _clean(parse_number(value, where))
        data = copy.deepcopy(self.data)
        t = data.setdefault(table, {})
        if v is None:
            t.pop(key, None)
        else:
            t[key] = v
        for k in replaces:
            t.pop(k, None)
        return self._validated(data)

    def add_light(self, kind: str = "strobe") -> "RigDoc":
        """A new document with one more light (a GN 24 strobe or a 3000 lm video light on a 0.4 m arm)."""
        data = copy.deepcopy(self.data)
        lights = data.setdefault("lights", [])
        names = {str(t.get("name", f"light{i}")) for i, t in enumerate(lights)}
        i = len(lights)
        while f"{kind}{i}" in names:
            i += 1
        new: dict[str, Any] = {"name": f"{kind}{i}", "kind": kind, "arm_length_m": 0.4,
                               "arm_angle_deg": 90.0, "arm_forward_m": 0.0, "yaw_deg": 0.0, "pitch_deg": 0.0,
                               "beam_angle_deg": 100.0}
        if kind == "strobe":
            new.update(spectrum=DEFAULT_SPECTRUM[kind], guide_number_m=24.0)
        elif kind == "video":
            new.update(spectrum=DEFAULT_SPECTRUM[kind], lumens=3000.0)
        else:
            raise ConfigError(f"unknown light kind {kind!r}", field="kind", allowed="strobe, video")
        lights.append(new)
        return self._validated(data)

    def remove_light(self, index: int) -> "RigDoc":
        data = copy.deepcopy(self.data)
        lights = data.get("lights", [])
        if not 0 <= index < len(lights):
            raise ConfigError(f"no light number {index}", field="lights")
        del lights[index]
        return self._validated(data)


# ---------------------------------------------------------------------- TOML writer

def _key(k: str) -> str:
    if k and all(c.isalnum() or c in "_-" for c in k):
        return k
    return json.dumps(k, ensure_ascii=False)


def _value(v: Any, where: str) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if not math.isfinite(v):
            raise ConfigError(f"cannot write a non-finite number ({v})", field=where)
        s = repr(v)  # shortest text that reads back to the same float
        return s if any(c in s for c in ".e") else s + ".0"
    if isinstance(v, str):
        # JSON's string escapes (\" \\ \n \t \uXXXX) are valid TOML basic-string escapes
        return json.dumps(v, ensure_ascii=False)
    if isinstance(v, (list, tuple)):
        if any(isinstance(x, dict) for x in v):
            raise ConfigError("nested tables inside arrays are not part of the rig format", field=where)
        return "[" + ", ".join(_value(x, where) for x in v) + "]"
    if isinstance(v, np.generic):
        return _value(v.item(), where)
    raise ConfigError(f"cannot write a {type(v).__name__} to TOML", field=where)


def _table_lines(t: dict, where: str) -> list[str]:
    out = []
    for k, v in t.items():
        if isinstance(v, dict):
            raise ConfigError("nested tables are not part of the rig format", field=f"{where}.{k}")
        if v is None:
            continue
        out.append(f"{_key(k)} = {_value(v, f'{where}.{k}')}")
    return out


def dumps_toml(data: dict, *, header: str | None = None) -> str:
    """Write a rig table as TOML: top-level scalars, then ``[table]`` sections and ``[[array]]`` tables.

    Tables come in the order of the shipped rigs (``rig``, ``camera``, ``port``,
    ``lights``), then any others.  ``toml_from_text(dumps_toml(d)) == d`` for rig
    tables (numbers, strings, booleans, arrays of them, one level of tables).
    """
    lines: list[str] = []
    if header:
        lines += [f"# {line}".rstrip() for line in header.splitlines()]
        lines.append("")
    scalars = {k: v for k, v in data.items() if not isinstance(v, (dict, list)) or
               (isinstance(v, list) and not any(isinstance(x, dict) for x in v))}
    lines += _table_lines(scalars, "")
    if scalars:
        lines.append("")
    keys = [k for k in _TABLE_ORDER if k in data] + [k for k in data if k not in _TABLE_ORDER]
    for k in keys:
        v = data[k]
        if k in scalars:
            continue
        if isinstance(v, dict):
            lines.append(f"[{_key(k)}]")
            lines += _table_lines(v, k)
            lines.append("")
        elif isinstance(v, list):
            for i, item in enumerate(v):
                lines.append(f"[[{_key(k)}]]")
                lines += _table_lines(item, f"{k}[{i}]")
                lines.append("")
    return "\n".join(lines).rstrip("\n") + "\n"
