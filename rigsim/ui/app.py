"""The rig designer: a trame web app over the rigsim API (``rigsim app``).

Left: the rig (file, camera and port, each light's arm, aim, beam, power and
spectrum), the water (preset or constituents, depth), the subject (target,
distance, size) and the camera (sensor, exposure, white balance).  Middle: the
3-D layout (PyVista, rendered on the server and streamed as images, so the page
needs no GPU) next to the predicted photograph and its numbers.  Bottom: the
same rig across waters or distances, or two rigs, side by side, with a
contrast-versus-distance plot.

Every edit is validated by the same parser as the CLI; a refused edit shows the
parser's one-line message and leaves the last valid rig in use.  Work runs in one
background thread: the preview (about a second), then the comparison; a new edit
supersedes stale work, and cancels a converged render in progress.

Files are read and written only inside ``rigs/`` and the ``--workdir`` folder
(:class:`rigsim.ui.files.FileSandbox`); waters, sensors and spectra are chosen
from lists, never from paths a browser sends.
"""

from __future__ import annotations

import asyncio
import base64
import dataclasses
import io
import json
import logging
import math
import threading
import time
from collections import OrderedDict
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

from rigsim.errors import ConfigError, RigsimError
from rigsim.ui.files import FileSandbox, default_rigs_dir
from rigsim.ui.handles import LightHandles, ensure_interactor, on_plane
from rigsim.ui.predict import (COMPARE, PREVIEW, QUALITIES, Quality, TARGETS, WHITE_BALANCES, Conditions, Prediction,
                               contrast_curve, load_water_cached, predict, preview_engine)
from rigsim.config.rigdoc import SPECTRA, RigDoc, parse_number

log = logging.getLogger(__name__)

__all__ = ["RigDesigner", "create_app", "main", "check_options", "is_loopback", "DEFAULT_RIG"]

#: The rig the designer opens with.
DEFAULT_RIG = "twin-strobes-45-wide.toml"
DEFAULT_WATER = "coastal"
DEFAULT_SENSOR = "sony_ilce-7rm2"
#: Distances of the contrast-versus-distance curve (m).
CURVE_DISTANCES_M = (0.5, 1.0, 1.5, 2.0, 3.0, 4.0)
TARGET_SIZES = {"real size": None, "fills 25% of frame": 0.25, "fills 50% of frame": 0.5,
                "fills 75% of frame": 0.75}
MAX_COMPARE = 4
_DEBOUNCE_S = 0.15
#: Least time between redraws of the 3-D view while a light is dragged (s; a redraw takes ~0.13 s).
_DRAG_REDRAW_S = 0.25

#: UI variable of each editable light field (flat keys for the selected light).
LIGHT_VARS = {"l_name": "name", "l_arm_length_m": "arm_length_m", "l_arm_angle_deg": "arm_angle_deg",
              "l_arm_forward_m": "arm_forward_m", "l_yaw_deg": "yaw_deg", "l_pitch_deg": "pitch_deg",
              "l_beam_angle_deg": "beam_angle_deg", "l_spectrum": "spectrum",
              "l_guide_number_m": "guide_number_m", "l_flash_energy_J": "flash_energy_J",
              "l_power_fraction": "power_fraction", "l_lumens": "lumens"}
AIM_AT_VARS = ("l_aim_r", "l_aim_u", "l_aim_f")
CAMERA_VARS = {"c_focal_length_mm": "focal_length_mm", "c_f_number": "f_number",
               "c_housing_radius_m": "housing_radius_m", "c_port_kind": "port_kind",
               "c_port_radius_m": "port_radius_m", "c_rig_name": "rig_name"}
#: Seconds after the last edit at which every page is sent the server's values of what was edited.
_RESYNC_S = 0.4
COND_VARS = ("water", "use_constituents", "chl", "cdom", "small", "large", "depth_m", "distance_m", "target",
             "target_size", "sensor", "exposure_mode", "shutter_inv", "iso", "flash_pct", "white_balance", "particles")


#: The values the file buttons carry with their clicks (Save, Load: :meth:`RigDesigner._shown`), read nowhere else:
#: each page's own, so never sent back to the pages.  Sent back, one crossed a newer value being typed — the page's
#: state then held the previous "save as" name while its field showed the new one, and Save carried the previous one
#: (the browser test, 2026-12-05: "../escape.toml" typed within 0.4 s of refusing "/tmp/x.toml").
_CARRIED_BY_CLICKS = ("save_name", "save_folder", "save_overwrite", "file_sel")

#: The variables pages edit (their server values are sent back to every page after edits).
_EDITABLE = tuple(LIGHT_VARS) + AIM_AT_VARS + tuple(CAMERA_VARS) + COND_VARS + (
    "light_index", "l_aim_mode", "l_power_mode", "compare_mode", "compare_waters", "compare_distances",
    "compare_rig_b", "compare_auto", "render_quality")


class _Cancelled(Exception):
    pass


def png_data_url(rgb8: np.ndarray) -> str:
    import cv2

    ok, buf = cv2.imencode(".png", np.ascontiguousarray(np.asarray(rgb8)[..., ::-1]))
    if not ok:
        return ""
    return "data:image/png;base64," + base64.b64encode(buf.tobytes()).decode("ascii")


def fmt_shutter(t: float) -> str:
    return f"1/{1 / t:.0f} s" if t < 0.5 else f"{t:.2g} s"


def metric_rows(pred: Prediction) -> list[dict]:
    """Label, value text and raw value of each number under an image."""
    m = pred.metrics
    rows = []

    def add(key, label, text, hint):
        rows.append({"key": key, "label": label, "text": text, "value": m.get(key), "hint": hint})

    add("contrast_radiance", "Contrast (scene)",
        f"{m['contrast_radiance']:.3f}" if "contrast_radiance" in m else "–",
        "Michelson contrast of the target in the light reaching the port (white vs black patch)")
    add("contrast_image", "Contrast (image)", f"{m['contrast_image']:.3f}" if "contrast_image" in m else "–",
        "the same in the developed photograph")
    add("backscatter_share", "Backscatter", f"{100 * m['backscatter_share']:.1f} %" if "backscatter_share" in m
        else "–", "share of the target pixels' light scattered back by the water")
    if "snr_white" in m:
        snr = m["snr_white"]
        add("snr_white", "SNR (white)", f"{snr:.0f} : 1  ({20 * math.log10(max(snr, 1e-9)):.1f} dB)",
            "sensor temporal SNR at the white patch (EMVA 1288)")
    else:
        add("snr_white", "SNR (white)", "–", "sensor temporal SNR at the white patch (EMVA 1288)")
    add("delta_e_mean", "Colour error ΔE2000", f"{m['delta_e_mean']:.1f}" if "delta_e_mean" in m else "–",
        "mean over the 24 chart patches vs the chart in daylight (after white balance)")
    if m.get("speck_count") is not None and "speck_share" in m:
        add("speck_count", "Specks (marine snow)", f"{m['speck_count']:.0f}  ({100 * m['speck_share']:.1f} % of the light)",
            "particles lit to at least 5 % of the subject's brightness, and the particles' share of the image's light")
    return rows


def agreement_text(water: str, *, rig: str | None = None, converged: bool = False) -> str:
    """How far the preview (fast engine) is from Monte Carlo in this water with this rig (its name), from the
    published benchmark (:func:`rigsim.metrics.agreement.published_agreement`)."""
    if converged:
        return "This is a Monte Carlo render (the reference the preview is checked against)."
    from rigsim.metrics.agreement import published_agreement

    pub = published_agreement(Path(water).stem if water.endswith(".toml") else water, rig=rig)
    if pub is None:
        return (f"The fast engine has not been checked against Monte Carlo in {water} water: press Render for "
                "a converged image, or run benchmarks/bench_fast_engine_agreement.py --waters ... --publish.")
    text = pub.sentence(rig)
    return text[0].upper() + text[1:] + "."


def exposure_text(pred: Prediction) -> str:
    e = pred.exposure
    parts = [fmt_shutter(e["shutter_s"]), f"ISO {e['iso']:.0f}", f"f/{e['f_number']:g}"]
    if e.get("flash_scale") is not None:
        parts.append(f"strobes at {100 * e['flash_scale']:.0f}%")
    parts.append(f"WB {e['white_balance']}")
    text = " · ".join(parts)
    if pred.notes:
        text += " — " + "; ".join(pred.notes)
    return text


def curve_svg(series: list[dict], current_m: float) -> str:
    """Contrast (solid) and backscatter share (dashed) against distance, one colour per series."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(5.2, 3.0), dpi=100)
    ax2 = ax.twinx()
    colours = ["#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e"]
    for i, s in enumerate(series):
        pts = [p for p in s["points"] if p.get("contrast_radiance") is not None]
        if not pts:
            continue
        c = colours[i % len(colours)]
        d = [p["distance_m"] for p in pts]
        ax.plot(d, [p["contrast_radiance"] for p in pts], "-o", color=c, ms=3.5, lw=1.8, label=s["label"])
        bs = [(p["distance_m"], p["backscatter_share"]) for p in pts if p.get("backscatter_share") is not None]
        if bs:
            ax2.plot(*zip(*bs), "--", color=c, lw=1.0, alpha=0.7)
    ax.axvline(current_m, color="0.5", lw=0.8, ls=":")
    ax.set_xlabel("distance to subject (m)")
    ax.set_ylabel("contrast (scene), solid")
    ax2.set_ylabel("backscatter share, dashed")
    ax.set_ylim(0, 1.0)
    ax2.set_ylim(0, 1.0)
    ax.grid(alpha=0.3)
    if any(s["points"] for s in series):
        ax.legend(fontsize=8, loc="lower left")
    fig.tight_layout()
    buf = io.StringIO()
    fig.savefig(buf, format="svg")
    plt.close(fig)
    return "data:image/svg+xml;base64," + base64.b64encode(buf.getvalue().encode()).decode("ascii")


class _LRU(OrderedDict):
    def __init__(self, n: int):
        super().__init__()
        self.n = n

    def put(self, k, v):
        self[k] = v
        self.move_to_end(k)
        while len(self) > self.n:
            self.popitem(last=False)


class RigDesigner:
    """State, callbacks and layout of the rig designer on one trame server."""

    def __init__(self, server, sandbox: FileSandbox, *, rig_path: str | Path | None = None,
                 view: str = "server", preview_width: int = PREVIEW.width):
        import pyvista as pv

        #: the live preview's size (``rigsim app --preview-width``)
        self.preview_quality = dataclasses.replace(PREVIEW, width=int(preview_width))

        self.server = server
        self.state = server.state
        self.ctrl = server.controller
        self.sandbox = sandbox
        self.view_mode = view
        self.pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix="rigsim-ui")
        self.gen = 0
        #: the comparison's own generation: a new comparison (a click, a changed comparison setting)
        #: supersedes the one in flight without invalidating the preview or a converged render
        self._compare_gen = 0
        self._wake: asyncio.Event | None = None
        self._cancel_render = threading.Event()
        self._render_task = None
        self._cache_pred = _LRU(64)
        self._cache_curve = _LRU(512)
        # the last few renders of the live preview (a 960x640 one with its layers is ~0.2 GB) and of the comparison's
        # cells: an edit of the sensor, exposure or white balance re-develops one of them (rigsim.ui.predict.predict);
        # touched by the one worker thread only
        self._cache_render = {"preview": _LRU(2), "compare": _LRU(8)}
        self._drawn: set[str] = set()
        self._camera_set = False
        self.pinned: RigDoc | None = None

        pv.OFF_SCREEN = True
        self.plotter = pv.Plotter(off_screen=True, window_size=(720, 480))
        self.plotter.enable_trackball_style() if hasattr(self.plotter, "enable_trackball_style") else None
        self.handles: LightHandles | None = None
        if view == "server":  # drag handles need the server's interactor (see rigsim.ui.handles)
            self.handles = LightHandles(self.plotter.renderer, ensure_interactor(self.plotter.ren_win),
                                        on_press=self._handle_pressed, on_moved=self._handle_moved,
                                        on_drag=self._handle_dragged)
        self._drag_drawn = 0.0
        self._touched: set[str] = set()
        self._resync_handle = None

        path = Path(rig_path) if rig_path else default_rigs_dir() / DEFAULT_RIG
        try:
            self.doc = RigDoc.load(path)
        except RigsimError as exc:
            log.warning("cannot open %s (%s); starting from an empty rig", path, exc)
            self.doc = RigDoc({"rig": {"name": "new-rig"}, "camera": {}, "port": {}, "lights": []})
        self.rig = self.doc.rig()
        self.cond = Conditions(water=DEFAULT_WATER, sensor=DEFAULT_SENSOR)
        self._init_state()
        self._register()
        self._layout()

    # ----------------------------------------------------------------- state
    def _file_items(self):
        return [{"title": f"{f['folder']}/{f['name']}", "value": f"{f['folder']}/{f['name']}"}
                for f in self.sandbox.list_files()]

    def _init_state(self):
        from rigsim.sensor import available_sensors
        from rigsim.water import preset_names

        s = self.state
        self.waters = list(preset_names())
        from rigsim.water.particles import particle_level_names

        self.particle_levels = ["none", *particle_level_names()]
        self.sensors = list(available_sensors())
        s.update({
            "engine": preview_engine()[0],
            "message": "", "message_type": "info",
            "file_items": self._file_items(), "file_sel": None,
            "folder_items": list(self.sandbox.folders), "save_folder": list(self.sandbox.folders)[-1],
            "save_name": f"{self.doc.name}.toml", "save_overwrite": False,
            "file_message": "", "file_message_type": "info",
            "light_items": [], "light_index": 0, "has_lights": False,
            "l_kind": "strobe", "l_aim_mode": "angles", "l_power_mode": "guide_number", "l_beam_mode": "cone",
            "l_beam_profile": "", "spectrum_items": list(SPECTRA),
            "water_items": self.waters, "water": self.cond.water, "use_constituents": False,
            "chl": None, "cdom": None, "small": None, "large": None, "constituents_ok": True,
            "particle_items": self.particle_levels, "particles": self.cond.particles,
            "depth_m": self.cond.depth_m, "distance_m": self.cond.distance_m,
            "target_items": list(TARGETS), "target": self.cond.target,
            "target_size_items": list(TARGET_SIZES), "target_size": "fills 50% of frame",
            "sensor_items": self.sensors, "sensor": self.cond.sensor,
            "exposure_mode": "auto", "shutter_inv": 125, "iso": 100, "flash_pct": 100,
            "wb_items": list(WHITE_BALANCES), "white_balance": "auto",
            "preview_src": "", "preview_title": "", "preview_info": "starting…", "preview_gen": 0,
            "agreement_text": "",
            "preview_busy": True, "metric_rows": [], "metric_values": {}, "exposure_text": "",
            "render_quality_items": list(QUALITIES), "render_quality": list(QUALITIES)[1],
            "render_running": False, "render_progress": 0, "render_message": "",
            "optimise_running": False, "optimise_progress": 0,
            "compare_mode": "waters", "compare_mode_items": [
                {"title": "Waters (same rig, same distance)", "value": "waters"},
                {"title": "Distances (same rig, same water)", "value": "distances"},
                {"title": "Two rigs (this rig vs B)", "value": "rigs"}],
            "compare_waters": ["coastal", "clear"], "compare_distances": "0.75, 1.5, 3",
            "compare_rig_b": None, "compare_rig_items": [], "compare_auto": True,
            "compare_cells": [], "compare_plot": "", "compare_busy": False, "compare_info": "",
            "water_rgb": "#206060",
        })
        for v in list(LIGHT_VARS) + list(AIM_AT_VARS) + list(CAMERA_VARS):
            s[f"err_{v}"] = []
        self._sync_rig_vars()

    def _compare_rig_items(self):
        items = [{"title": "pinned copy of this rig", "value": "@pinned"}] if self.pinned else []
        return items + self._file_items()

    def _sync_rig_vars(self):
        """Push the document's values into the UI variables (after load, light switch, mode change)."""
        s = self.state
        names = self.doc.light_names()
        s.light_items = [{"title": f"{i + 1}: {n}", "value": i} for i, n in enumerate(names)]
        s.has_lights = bool(names)
        i = self._index()
        if names:
            v = self.doc.light_view(i)
            for var, key in LIGHT_VARS.items():
                s[var] = v[key]
            for var, x in zip(AIM_AT_VARS, v["aim_at_m"]):
                s[var] = x
            s.l_kind, s.l_aim_mode, s.l_power_mode = v["kind"], v["aim_mode"], v["power_mode"]
            s.l_beam_mode, s.l_beam_profile = v["beam_mode"], v["beam_profile"]
            s.spectrum_items = list(SPECTRA) + ([v["spectrum"]] if v["spectrum"] not in SPECTRA else [])
        cv = self.doc.camera_view()
        for var, key in CAMERA_VARS.items():
            s[var] = cv[key]
        for v in list(LIGHT_VARS) + list(AIM_AT_VARS) + list(CAMERA_VARS):
            s[f"err_{v}"] = []
        s.compare_rig_items = self._compare_rig_items()

    def _index(self) -> int:
        """The selected light: ``light_index`` if a page sent a usable one, else 0 (and the state says 0)."""
        v = self.state.light_index
        n = len(self.doc.light_names())
        if (isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) and v == int(v)
                and 0 <= int(v) < max(n, 1)):
            return int(v)
        self.state.light_index = 0
        return 0

    # ----------------------------------------------------------------- edits
    def _say(self, text: str, kind: str = "info"):
        self.state.message, self.state.message_type = text, kind

    def _refuse(self, var: str | None, exc: Exception):
        text = str(exc)
        self._say(f"Refused: {text}", "error")
        if var:
            self.state[f"err_{var}"] = [text.split(": ", 1)[-1] if len(text) > 90 else text]

    def _accept(self, doc: RigDoc, var: str | None = None):
        self.doc = doc
        self.rig = doc.rig()
        if var:
            self.state[f"err_{var}"] = []
        if self.state.message_type == "error":
            self._say("")
        self._changed()

    def _on_light_var(self, var: str, value):
        if not self.state.has_lights:
            return
        i = self._index()
        key = LIGHT_VARS[var]
        current = self.doc.light_view(i)[key]
        if key == "spectrum":
            value = str(value)
            if value not in SPECTRA and not value.startswith("blackbody:") and value != current:
                self._refuse(var, ConfigError("choose a named spectrum or blackbody:T (K)",
                                              field=f"lights[{i}].spectrum", allowed=", ".join(SPECTRA)))
                return
        if key not in ("name", "spectrum"):
            try:
                if abs(parse_number(value, key) - float(current)) < 1e-9:
                    self.state[f"err_{var}"] = []
                    return
            except ConfigError as exc:
                self._refuse(var, ConfigError(exc.message, field=f"lights[{i}].{key}"))
                return
        elif str(value) == str(current):
            return
        try:
            doc = self.doc.edit_light(i, key, value)
        except ConfigError as exc:
            self._refuse(var, exc)
            return
        self._accept(doc, var)
        if key == "name":
            self.state.light_items = [{"title": f"{j + 1}: {n}", "value": j}
                                      for j, n in enumerate(self.doc.light_names())]

    def _on_aim_at(self, **_):
        if not self.state.has_lights or self.state.l_aim_mode != "point":
            return
        i = self._index()
        vals = [self.state[v] for v in AIM_AT_VARS]
        cur = self.doc.light_view(i)
        try:
            nums = [parse_number(x, f"lights[{i}].aim_at_m") for x in vals]
        except ConfigError as exc:
            self._refuse("l_aim_f", exc)
            return
        if "aim_at_m" in self.doc.data["lights"][i] and np.allclose(nums, cur["aim_at_m"], atol=1e-9):
            return
        try:
            doc = self.doc.edit_light(i, "aim_at_m", nums)
        except ConfigError as exc:
            self._refuse("l_aim_f", exc)
            return
        self._accept(doc, "l_aim_f")

    def _on_mode(self, which: str, value):
        if not self.state.has_lights:
            return
        i = self._index()
        v = self.doc.light_view(i)
        try:
            if which == "aim" and value != v["aim_mode"]:
                doc = self.doc.set_aim_mode(i, value)
            elif which == "power" and value != v["power_mode"] and v["kind"] == "strobe":
                doc = self.doc.set_power_mode(i, value)
            else:
                return
        except ConfigError as exc:
            self._refuse(None, exc)
            return
        self._accept(doc)
        self._sync_rig_vars()

    def _on_camera_var(self, var: str, value):
        key = CAMERA_VARS[var]
        cur = self.doc.camera_view()[key]
        if key in ("port_kind", "rig_name"):
            if str(value) == str(cur):
                return
        else:
            try:
                if cur is not None and abs(parse_number(value, key) - float(cur)) < 1e-9:
                    self.state[f"err_{var}"] = []
                    return
            except ConfigError as exc:
                self._refuse(var, exc)
                return
        try:
            doc = self.doc.edit_camera(key, value)
        except ConfigError as exc:
            self._refuse(var, exc)
            return
        self._accept(doc, var)
        if key == "rig_name":
            self.state.save_name = f"{value}.toml"

    def _conditions(self) -> Conditions:
        """The conditions from the UI, validated (waters and sensors only from their lists)."""
        s = self.state
        if s.water not in self.waters:
            raise ConfigError(f"unknown water {s.water!r}", field="water", allowed="a preset from the list")
        overrides = ()
        if s.use_constituents:
            if s.water.lower().startswith("jerlov"):
                raise ConfigError("constituents apply to the six constituent presets, not Jerlov types",
                                  field="water")
            ov = []
            for var, key in (("chl", "chl_mg_per_m3"), ("cdom", "cdom_a440_per_m"),
                             ("small", "small_particles_ppm"), ("large", "large_particles_ppm")):
                val = s[var]
                if val is None or str(val).strip() == "":
                    continue
                x = parse_number(val, key)
                if x < 0 or x > 1000:
                    raise ConfigError(f"out of range: {x:g}", field=key, allowed="0 … 1000")
                ov.append((key, x))
            overrides = tuple(ov)
        if s.sensor not in self.sensors:
            raise ConfigError(f"unknown sensor {s.sensor!r}", field="sensor", allowed=", ".join(self.sensors))
        if s.target not in TARGETS:
            raise ConfigError(f"unknown target {s.target!r}", field="target", allowed=", ".join(TARGETS))
        if s.target_size not in TARGET_SIZES:
            raise ConfigError(f"unknown target size {s.target_size!r}", field="target_size")
        if s.white_balance not in WHITE_BALANCES:
            raise ConfigError(f"unknown white balance {s.white_balance!r}", field="white_balance")
        d = parse_number(s.distance_m, "distance_m")
        depth = parse_number(s.depth_m, "depth_m")
        if not 0 <= depth <= 200:
            raise ConfigError(f"out of range: {depth:g} m", field="depth_m", allowed="0 … 200 m")
        if not 0 < d <= 30:
            raise ConfigError(f"out of range: {d:g} m", field="distance_m", allowed="0 … 30 m")
        kw = {}
        if s.exposure_mode == "manual":
            inv = parse_number(s.shutter_inv, "shutter (1/s)")
            iso = parse_number(s.iso, "iso")
            fp = parse_number(s.flash_pct, "strobe output (%)")
            if not 0.5 <= inv <= 32000:
                raise ConfigError(f"out of range: 1/{inv:g} s", field="shutter", allowed="1/32000 … 2 s")
            if not 25 <= iso <= 409600:
                raise ConfigError(f"out of range: {iso:g}", field="iso", allowed="25 … 409600")
            if not 0 <= fp <= 100:
                raise ConfigError(f"out of range: {fp:g} %", field="strobe output", allowed="0 … 100 %")
            kw = {"shutter_s": 1.0 / inv, "iso": iso, "flash_scale": fp / 100.0}
        if s.particles not in self.particle_levels:
            raise ConfigError(f"unknown particle level {s.particles!r}", field="marine snow",
                              allowed=", ".join(self.particle_levels))
        return Conditions(water=s.water, water_overrides=overrides, distance_m=d, target=s.target,
                          target_fill=TARGET_SIZES[s.target_size], sensor=s.sensor,
                          exposure="manual" if s.exposure_mode == "manual" else "auto",
                          white_balance=s.white_balance, depth_m=depth, particles=s.particles, **kw)

    def _on_cond(self, **_):
        try:
            cond = self._conditions()
            load_water_cached(cond.water, cond.water_overrides, cond.particles)
        except ConfigError as exc:
            self._refuse(None, exc)
            return
        if self.state.message_type == "error":
            self._say("")
        if cond != self.cond:
            self.cond = cond
            self._changed()

    def _changed(self):
        self.gen += 1
        self.state.preview_busy = True
        if self.state.render_running:
            self._cancel_render.set()
        if self._wake is not None:
            self._wake.set()

    # ----------------------------------------------------------------- files
    def _clicked(self, **shown):
        """Take the values a button's page showed when it was clicked (sent with the click).

        The page defers its own state updates while a request is in flight but sends a click at
        once, so a name typed just before clicking Save could reach the server after the click:
        the click carries the values it acts on, and the server's state is brought in line (for values the
        rest of the page follows, as the selected light; Save and Load only read theirs: :meth:`_shown`)."""
        for key, value in shown.items():
            if value is not None:
                self.state[key] = value

    def _shown(self, **shown) -> dict:
        """The values a button's page showed when it was clicked (sent with the click), else the server's,
        without writing them back: a value the server sets is sent to the page, and one that arrives after the
        person has typed on (a busy server) overwrote the field with what they had typed before (seen: the
        name of the previous "save as" put back after a new one was typed, and saved again)."""
        return {key: (value if value is not None else self.state[key]) for key, value in shown.items()}

    def load_rig(self, file_sel=None):
        sel = self._shown(file_sel=file_sel)["file_sel"]
        try:
            if not sel or "/" not in str(sel):
                raise ConfigError("choose a rig file first", field="file")
            folder, name = str(sel).split("/", 1)
            path, text = self.sandbox.read_text(name, folder=folder)
            doc = RigDoc.loads(text, source=path.name, base_dir=path.parent)
        except ConfigError as exc:
            self.state.file_message, self.state.file_message_type = f"Refused: {exc}", "error"
            return
        self.state.light_index = 0
        self.doc = doc
        self.rig = doc.rig()
        self._sync_rig_vars()
        self.state.save_name = path.name
        self.state.file_message, self.state.file_message_type = f"Loaded {sel}", "success"
        self._say("")
        self._changed()

    def save_rig(self, save_name=None, save_folder=None, save_overwrite=None):
        shown = self._shown(save_name=save_name, save_folder=save_folder, save_overwrite=save_overwrite)
        s = self.state
        try:
            folder = shown["save_folder"] if shown["save_folder"] in self.sandbox.folders else None
            if folder is None:
                raise ConfigError("choose a folder", field="folder", allowed=", ".join(self.sandbox.folders))
            target = self.sandbox.resolve(str(shown["save_name"] or ""), folder=folder)
            doc = self.doc.relocated(target.parent, target.name)
            doc.rig()  # still valid from its new home (relative CSV paths)
            text = doc.to_toml(header=f"{doc.name}: saved by the rigsim rig designer.\n"
                                      "Format: rigs/README.md (frames: light positions [right, up, forward] in m).")
            RigDoc.loads(text, source=target.name, base_dir=target.parent)  # round trip before writing
            path = self.sandbox.write_text(str(shown["save_name"]), text, folder=folder,
                                           overwrite=bool(shown["save_overwrite"]))
        except ConfigError as exc:
            s.file_message, s.file_message_type = f"Refused: {exc}", "error"
            return
        s.file_message, s.file_message_type = f"Saved {folder}/{path.name}", "success"
        s.file_items = self._file_items()
        s.compare_rig_items = self._compare_rig_items()

    def add_light(self, kind: str = "strobe"):
        try:
            doc = self.doc.add_light(kind)
        except ConfigError as exc:
            self._refuse(None, exc)
            return
        self._accept(doc)
        self.state.light_index = len(self.doc.light_names()) - 1
        self._sync_rig_vars()

    def remove_light(self, light_index=None):
        self._clicked(light_index=light_index)
        if not self.state.has_lights:
            return
        try:
            doc = self.doc.remove_light(self._index())
        except ConfigError as exc:
            self._refuse(None, exc)
            return
        self._accept(doc)
        self.state.light_index = 0
        self._sync_rig_vars()

    def pin_rig(self):
        self.pinned = self.doc
        self.state.compare_rig_items = self._compare_rig_items()
        self.state.compare_rig_b = "@pinned"
        self.state.compare_mode = "rigs"
        self._say(f"Pinned '{self.doc.name}' as rig B — edit this rig and compare.", "info")
        self._changed()

    # ----------------------------------------------------------------- 3-D
    def update_3d(self, rig=None):
        """Redraw the 3-D view for the current rig (or ``rig``: a light being dragged)."""
        from rigsim.ui.predict import _scene
        from rigsim.ui.scene3d import draw, scene_parts, water_colour

        try:
            scene = _scene(rig or self.rig, self.cond)
        except ConfigError as exc:
            self._refuse(None, exc)
            return
        rgb = water_colour(scene.water, self.cond.depth_m)
        parts = scene_parts(scene, water_rgb=rgb, selected_light=self._index())
        self._drawn = draw(self.plotter, parts, background=rgb, previous=self._drawn)
        if self.handles is not None:
            self.handles.place([light.position_m for light in scene.lights], selected=self._index())
        self.state.water_rgb = "#%02x%02x%02x" % tuple(int(round(255 * c)) for c in rgb)
        if not self._camera_set:
            d = self.cond.distance_m
            focal = np.array([0.0, 0.0, d * 0.4])
            self.plotter.camera_position = [tuple(focal + np.array([-1.3, 0.9, -0.9]) * (0.9 + 0.8 * d)),
                                            tuple(focal), (0, 1, 0)]
            self._camera_set = True
        self.ctrl.view_update()

    def _handle_pressed(self, index: int):
        """A light's handle was grabbed in the 3-D view: select that light."""
        if index != self._index():
            with self.state:
                self.state.light_index = index

    def _local(self, world_m, index: int, free: bool) -> list[float]:
        """Where a handle dropped at ``world_m`` puts light ``index``, in the camera frame
        [right, up, forward] (m): on the line of sight through the handle, at the light's
        forward offset (unless ``free``, or the line is nearly parallel to that plane)."""
        cam = self.rig.camera
        pupil = np.asarray(cam.position_m, float)
        r, u, f = cam.frame()
        p = np.asarray(world_m, float)
        if not free:
            forward = self.doc.light_view(index)["arm_forward_m"]
            q = on_plane(self.plotter.camera.position, p, pupil + f * forward, f)
            p = q if q is not None else p
        return [float(np.dot(p - pupil, e)) for e in (r, u, f)]

    def _handle_dragged(self, index: int, world_m, free: bool):
        """While a handle is dragged, the light's head, arm and beam follow it (at most ~4 per s)."""
        now = time.perf_counter()
        if now - self._drag_drawn < _DRAG_REDRAW_S:
            return
        self._drag_drawn = now
        try:
            rig = self.doc.move_light(index, self._local(world_m, index, free)).rig()
        except ConfigError:
            return  # e.g. inside the housing: said when the handle is dropped
        self.update_3d(rig)

    def _handle_moved(self, index: int, world_m, free: bool):
        """A light's handle was dropped: move the light there (camera frame), or refuse and put it back."""
        with self.state:
            try:
                doc = self.doc.move_light(index, self._local(world_m, index, free))
            except ConfigError as exc:
                self._refuse(None, exc)
                self.update_3d()  # the handle goes back to where the light is
                return
            self.state.light_index = index
            self._accept(doc)  # the worker redraws the 3-D view and the preview
            self._sync_rig_vars()

    def view_behind(self):
        """Look along the lens axis from behind and slightly above the housing (image left is screen left)."""
        cam = self.rig.camera
        r, u, f = cam.frame()
        pupil = np.asarray(cam.position_m, float)
        # far enough back that every light (and the housing) is in the view with a margin
        reach = max([cam.housing_radius_m] + [float(np.hypot(np.dot(np.asarray(light.position_m) - pupil, r),
                                                             np.dot(np.asarray(light.position_m) - pupil, u)))
                                              for light in self.rig.lights])
        half_view = np.radians(self.plotter.camera.view_angle / 2)
        back = 1.35 * (reach + 0.1) / np.tan(half_view)
        eye = pupil - f * back + u * 0.15 * back
        self.plotter.camera_position = [tuple(eye), tuple(pupil + f * 0.3), tuple(u)]
        self._camera_set = True
        self.ctrl.view_update()

    def reset_camera(self):
        self._camera_set = False
        self.update_3d()

    # ----------------------------------------------------------------- work
    def _rig_key(self, doc: RigDoc) -> str:
        return json.dumps(doc.data, sort_keys=True, default=str) + str(doc.base_dir)

    async def _run(self, fn, *args, **kw):
        loop = asyncio.get_running_loop()
        return await loop.run_in_executor(self.pool, lambda: fn(*args, **kw))

    async def _predict_cached(self, doc: RigDoc, rig, cond: Conditions, label: str,
                              quality: Quality = PREVIEW) -> Prediction:
        key = (self._rig_key(doc), cond, quality.name)
        if key in self._cache_pred:
            p = self._cache_pred[key]
            return dataclasses.replace(p, label=label)
        p = await self._run(predict, rig, cond, label=label, quality=quality,
                            render_cache=self._cache_render.get(quality.name), rig_key=key[0])
        self._cache_pred.put(key, p)
        return p

    async def _worker(self):
        self._wake = asyncio.Event()
        self._wake.set()
        while True:
            await self._wake.wait()
            await asyncio.sleep(_DEBOUNCE_S)
            self._wake.clear()
            gen, doc, rig, cond = self.gen, self.doc, self.rig, self.cond
            with self.state:
                try:
                    self.update_3d()
                except Exception as exc:  # a drawing problem must not stop the app
                    log.exception("3-D view update failed")
                    self._say(f"3-D view not updated: {exc}", "warning")
            try:
                pred = await self._predict_cached(doc, rig, cond, label=rig.name, quality=self.preview_quality)
            except RigsimError as exc:
                with self.state:
                    self._refuse(None, exc)
                    self.state.preview_busy = False
                continue
            except Exception as exc:
                log.exception("preview failed")
                with self.state:
                    self._say(f"Preview failed: {type(exc).__name__}: {exc}", "error")
                    self.state.preview_busy = False
                continue
            if gen != self.gen:
                continue
            with self.state:
                self._publish(pred, converged=False)
            if self.state.compare_auto:
                self._compare_gen += 1
                await self._compare(gen, self._compare_gen)

    def _publish(self, pred: Prediction, *, converged: bool):
        s = self.state
        s.preview_src = png_data_url(pred.srgb)
        s.metric_rows = metric_rows(pred)
        s.metric_values = {k: float(v) for k, v in pred.metrics.items()}
        s.exposure_text = exposure_text(pred)
        kind = "converged render" if converged else "preview"
        s.preview_title = f"{kind}: {pred.label} · {self.cond.water} · {self.cond.distance_m:g} m · {self.cond.target}"
        s.preview_info = (f"{pred.engine} · {pred.width}×{pred.height} px · {pred.seconds:.2f} s"
                          + (" (the same render, photographed again)" if pred.reused else ""))
        s.agreement_text = agreement_text(self.cond.water, rig=self.rig.name, converged=converged)
        s.preview_gen = self.gen
        s.preview_busy = False

    def _compare_jobs(self, cond: Conditions):
        """(label, doc, rig, conditions) per comparison cell, and the curve series."""
        s = self.state
        mode = s.compare_mode
        jobs = []
        if mode == "waters":
            waters = [w for w in (s.compare_waters or []) if w in self.waters][:MAX_COMPARE]
            for w in waters:
                c = cond.replace(water=w, water_overrides=cond.water_overrides if w == cond.water else ())
                jobs.append((w, self.doc, self.rig, c))
        elif mode == "distances":
            try:
                ds = [parse_number(x, "distances") for x in str(s.compare_distances).replace(";", ",").split(",")
                      if x.strip()]
            except ConfigError as exc:
                raise ConfigError(exc.message, field="compare distances", allowed="numbers in m, e.g. 0.75, 1.5, 3")
            for d in ds[:MAX_COMPARE]:
                if not 0 < d <= 30:
                    raise ConfigError(f"out of range: {d:g} m", field="compare distances", allowed="0 … 30 m")
                jobs.append((f"{d:g} m", self.doc, self.rig, cond.replace(distance_m=d)))
        else:
            jobs.append((f"A: {self.doc.name}", self.doc, self.rig, cond))
            b = s.compare_rig_b
            if b == "@pinned" and self.pinned is not None:
                docb = self.pinned
            elif b and "/" in str(b):
                folder, name = str(b).split("/", 1)
                path, text = self.sandbox.read_text(name, folder=folder)
                docb = RigDoc.loads(text, source=path.name, base_dir=path.parent)
            else:
                raise ConfigError("choose rig B (a file, or pin this rig first)", field="rig B")
            jobs.append((f"B: {docb.name}", docb, docb.rig(), cond))
        return jobs

    async def _compare(self, gen: int, token: int):
        """Fill the comparison for edit generation ``gen``; a newer edit or comparison (``token``)
        supersedes it. Whoever stops a comparison leaves ``compare_busy`` true only while a newer
        comparison owns it."""
        s = self.state
        try:
            jobs = self._compare_jobs(self.cond)
        except ConfigError as exc:
            with s:
                s.compare_info = f"Refused: {exc}"
                s.compare_cells = []
                if token == self._compare_gen:
                    s.compare_busy = False
            return
        with s:
            s.compare_busy = True
            s.compare_info = "computing…"
        try:
            await self._compare_cells(jobs, gen, token)
        except Exception as exc:  # a failing comparison must not stop the app or leave it busy
            log.exception("comparison failed")
            with s:
                s.compare_info = f"Comparison failed: {type(exc).__name__}: {exc}"
        finally:
            if token == self._compare_gen and s.compare_busy:
                with s:
                    s.compare_busy = False
                    if s.compare_info == "computing…":
                        s.compare_info = "stopped: the setup changed (press Compare to fill it in again)"

    async def _compare_cells(self, jobs, gen: int, token: int):
        s = self.state

        def current() -> bool:
            return gen == self.gen and token == self._compare_gen
        cells = []
        t0 = time.perf_counter()
        for label, doc, rig, cond in jobs:
            if not current():
                return
            try:
                p = await self._predict_cached(doc, rig, cond, label, COMPARE)
            except RigsimError as exc:
                cells.append({"title": label, "src": "", "rows": [], "exposure": "", "error": str(exc)})
                continue
            cells.append({"title": label, "src": png_data_url(p.srgb), "rows": metric_rows(p),
                          "exposure": exposure_text(p), "error": ""})
            if current():
                with s:
                    s.compare_cells = list(cells)
        # contrast-versus-distance: one series per water / rig (one for "distances")
        series_jobs = jobs if s.compare_mode != "distances" else [(self.cond.water, self.doc, self.rig, self.cond)]
        series = [{"label": lab, "points": []} for lab, *_ in series_jobs]
        for si, (label, doc, rig, cond) in enumerate(series_jobs):
            for d in CURVE_DISTANCES_M:
                if not current():
                    return
                key = (self._rig_key(doc), cond.replace(distance_m=1.0, sensor="-", exposure="auto"), d)
                if key not in self._cache_curve:
                    try:
                        pts = await self._run(contrast_curve, rig, cond, [d])
                    except RigsimError:
                        pts = []
                    self._cache_curve.put(key, pts[0] if pts else None)
                pt = self._cache_curve[key]
                if pt is not None:
                    series[si]["points"].append(pt)
            if current():
                with s:
                    s.compare_plot = curve_svg(series, self.cond.distance_m)
        if current():
            with s:
                s.compare_busy = False
                s.compare_info = f"{len(cells)} images, {sum(len(x['points']) for x in series)} curve points · " \
                                 f"{time.perf_counter() - t0:.1f} s"

    def compare_now(self):
        self._compare_gen += 1
        asyncio.ensure_future(self._compare(self.gen, self._compare_gen))

    def render_converged(self, render_quality=None):
        self._clicked(render_quality=render_quality)
        if self.state.render_running:
            return
        self._render_task = asyncio.ensure_future(self._render())

    def cancel_render(self):
        self._cancel_render.set()

    async def _render(self):
        s = self.state
        q = QUALITIES.get(s.render_quality) or list(QUALITIES.values())[0]
        loop = asyncio.get_running_loop()
        gen, rig, cond = self.gen, self.rig, self.cond
        self._cancel_render.clear()
        with s:
            s.render_running, s.render_progress, s.render_message = True, 0, f"rendering {q.name}…"

        def progress(frac, msg):
            if self._cancel_render.is_set():
                raise _Cancelled()
            loop.call_soon_threadsafe(self._progress, frac, msg)

        t0 = time.perf_counter()
        try:
            pred = await self._run(predict, rig, cond, quality=q, label=rig.name, progress=progress)
        except _Cancelled:
            with s:
                s.render_running, s.render_message = False, "render cancelled (the setup changed or you cancelled)"
            return
        except RigsimError as exc:
            with s:
                s.render_running, s.render_message = False, f"Refused: {exc}"
            return
        except Exception as exc:
            log.exception("render failed")
            with s:
                s.render_running, s.render_message = False, f"render failed: {type(exc).__name__}: {exc}"
            return
        with s:
            s.render_running = False
            s.render_progress = 100
            if gen == self.gen:
                self._publish(pred, converged=True)
                s.render_message = f"converged render done in {time.perf_counter() - t0:.1f} s"
            else:
                s.render_message = "render finished for an older setup; discarded"

    def optimise_rig(self):
        """Search the placement of the current rig's lights for the current water, distance, sensor and
        marine snow (:func:`rigsim.optimise.search.optimise`, the same search as ``rigsim optimise``); the
        rig as it was is pinned as rig B, so the comparison panel shows before and after."""
        if self.state.optimise_running:
            return
        asyncio.ensure_future(self._optimise())

    async def _optimise(self):
        from rigsim.optimise.objective import Setting
        from rigsim.optimise.output import sentence
        from rigsim.optimise.search import optimise

        s = self.state
        cond, doc = self.cond, self.doc
        if cond.water_overrides:
            self._say("Refused: the optimiser takes the water as named (switch the constituent overrides off)", "error")
            return
        loop = asyncio.get_running_loop()
        with s:
            s.optimise_running, s.optimise_progress = True, 0
            self._say(f"optimising the placement of {doc.name}'s lights for {cond.water} at {cond.distance_m:g} m…")

        def progress(frac, msg):
            def show():
                with self.state:
                    self.state.optimise_progress = int(round(100 * frac))
                    self._say(f"optimising: {msg} ({100 * frac:.0f}%)")
            loop.call_soon_threadsafe(show)

        try:
            setting = Setting(water=cond.water, distance_m=cond.distance_m, sensor=cond.sensor, subject="colorchecker",
                              subject_fill=cond.target_fill or 0.6, particles=cond.particles)
            opt = await self._run(optimise, doc, setting, progress=progress)
        except RigsimError as exc:
            with s:
                s.optimise_running = False
                self._say(f"Refused: {exc}", "error")
            return
        except Exception as exc:
            log.exception("optimisation failed")
            with s:
                s.optimise_running = False
                self._say(f"optimisation failed: {type(exc).__name__}: {exc}", "error")
            return
        with s:
            s.optimise_running = False
            if self.doc is not doc or self.cond != cond:
                self._say("the optimisation finished for an older setup; discarded (press Optimise again)", "warning")
                return
            if opt.best_doc is not doc:
                self.pin_rig()
                self._accept(opt.best_doc)
                self._sync_rig_vars()
                self.update_3d()
            self._say(sentence(opt) + " The rig as it was is pinned as rig B; Save keeps the new one.", "success")

    def _progress(self, frac, msg):
        with self.state:
            self.state.render_progress = int(round(100 * frac))
            self.state.render_message = f"rendering: {msg} ({100 * frac:.0f}%)"

    # ----------------------------------------------------------------- wiring
    def _register(self):
        s, c = self.state, self.ctrl
        for var in LIGHT_VARS:
            s.change(var)(lambda _v=var, **kw: self._on_light_var(_v, kw[_v]))
        for var in CAMERA_VARS:
            s.change(var)(lambda _v=var, **kw: self._on_camera_var(_v, kw[_v]))
        s.change(*AIM_AT_VARS)(self._on_aim_at)
        s.change("l_aim_mode")(lambda l_aim_mode, **_: self._on_mode("aim", l_aim_mode))
        s.change("l_power_mode")(lambda l_power_mode, **_: self._on_mode("power", l_power_mode))
        s.change(*COND_VARS)(self._on_cond)

        @s.change("light_index")
        def _light(**_):
            self._sync_rig_vars()
            self._changed()

        @s.change("compare_mode", "compare_waters", "compare_distances", "compare_rig_b")
        def _cmp(**_):
            if self.state.compare_auto:
                self.compare_now()

        c.load_rig = self.load_rig
        c.save_rig = self.save_rig
        c.add_strobe = lambda: self.add_light("strobe")
        c.add_video = lambda: self.add_light("video")
        c.remove_light = self.remove_light
        c.pin_rig = self.pin_rig
        c.render_converged = self.render_converged
        c.view_behind = self.view_behind
        c.cancel_render = self.cancel_render
        c.optimise_rig = self.optimise_rig
        c.compare_now = self.compare_now
        c.reset_camera = self.reset_camera
        c.on_server_ready.add(lambda **_: asyncio.ensure_future(self._worker()))
        s.change(*_EDITABLE)(self._note_edit)

    # ----------------------------------------------------------------- several pages
    def _note_edit(self, **_):
        """Remember what pages edited; soon after the last edit, send every page the server's values.

        trame forwards one page's edit to the others in a message sent a moment later, addressed
        to "every page but the one that sent the last message" as it is when the message goes out:
        with two pages editing at once, a page can miss the other's last edit or get its own older
        value back, and then show a value the server does not hold.  The server's values, sent to
        every page once the edits stop, make all pages agree with it again."""
        self._touched |= set(self.state.modified_keys) & set(_EDITABLE)
        if not self._touched:
            return
        try:
            loop = asyncio.get_running_loop()
        except RuntimeError:  # no event loop (in-process tests): nothing to send to
            return
        if self._resync_handle is not None:
            self._resync_handle.cancel()
        self._resync_handle = loop.call_later(_RESYNC_S, self._resync)

    def _resync(self):
        self._resync_handle = None
        keys, self._touched = sorted(self._touched), set()
        proto = getattr(self.server, "protocol", None)
        if proto is None or not keys:
            return
        try:
            proto.force_push_state(*[k for k in keys if k in self.state])
        except Exception:  # noqa: BLE001 - a page that went away must not stop the app
            log.exception("could not send the state to the pages")

    # ----------------------------------------------------------------- layout
    def _layout(self):
        from rigsim.ui import layout

        layout.build(self)


def create_app(*, rigs_dir: str | Path | None = None, workdir: str | Path | None = None,
               rig: str | Path | None = None, name: str = "rigsim", view: str = "server",
               preview_width: int = PREVIEW.width) -> RigDesigner:
    """A :class:`RigDesigner` on a fresh trame server (not started)."""
    from trame.app import get_server

    folders: dict[str, Path] = {"rigs": Path(rigs_dir) if rigs_dir else default_rigs_dir()}
    if workdir:
        w = Path(workdir).expanduser()
        if not w.is_dir():
            raise ConfigError("the work folder does not exist", file=w, field="--workdir",
                              allowed="an existing folder")
        folders["work"] = w
    server = get_server(name, client_type="vue3")
    rig_path = None
    if rig:
        rig_path = FileSandbox(folders).resolve(str(rig), folder="work" if "work" in folders else "rigs")
    return RigDesigner(server, FileSandbox(folders), rig_path=rig_path, view=view, preview_width=preview_width)


def is_loopback(host: str) -> bool:
    """True if ``host`` is only reachable from this machine (127.0.0.0/8, ::1, localhost)."""
    import ipaddress

    h = str(host).strip().strip("[]")
    if h.lower() == "localhost":
        return True
    try:
        return ipaddress.ip_address(h).is_loopback
    except ValueError:
        return False


def check_options(*, host: str = "127.0.0.1", port: int = 8080, workdir: str | Path | None = None,
                  rig: str | Path | None = None) -> list[str]:
    """Check the server's options before anything starts; the warnings to show (one line each).

    Raises
    ------
    ConfigError
        A port outside 1–65535, a host name that does not resolve, a missing --workdir.
    """
    import socket

    if isinstance(port, bool) or not isinstance(port, int) or not 1 <= port <= 65535:
        raise ConfigError(f"not a TCP port: {port!r}", field="--port", allowed="1 … 65535")
    text = str(host).strip()
    if not text or any(ord(c) < 32 for c in text) or len(text) > 253:
        raise ConfigError(f"not a host address: {text[:60]!r}", field="--host",
                          allowed="127.0.0.1 (default), 0.0.0.0 (every interface) or an address of this machine")
    try:
        socket.getaddrinfo(text.strip("[]"), port, type=socket.SOCK_STREAM)
    except (OSError, UnicodeError, ValueError) as exc:
        raise ConfigError(f"cannot listen on {text!r}: {exc}", field="--host",
                          allowed="127.0.0.1 (default), 0.0.0.0 (every interface) or an address of this machine") from None
    if workdir:
        w = Path(workdir).expanduser()
        if not w.is_dir():
            raise ConfigError("the work folder does not exist", file=w, field="--workdir",
                              allowed="an existing folder")
    warnings_ = []
    if not is_loopback(text):
        warnings_.append(f"the rig designer listens on {text}:{port}, not only on this machine: anyone who can reach "
                         "it there can open the designer and read and write rig files in rigs/ and --workdir "
                         "(there is no login); the default --host 127.0.0.1 keeps it local")
    return warnings_


def main(*, host: str = "127.0.0.1", port: int = 8080, workdir: str | None = None, rigs_dir: str | None = None,
         rig: str | None = None, open_browser: bool = False, view: str = "server",
         preview_width: int = PREVIEW.width) -> None:
    """Start the rig designer and serve it until interrupted.

    Listens on 127.0.0.1 unless another ``host`` is asked for (then with a warning).  Before
    anything starts: the options are checked (:func:`check_options`) and, for the server-drawn
    3-D view, that off-screen OpenGL works (:func:`rigsim.environment.check_offscreen_gl`).
    """
    import socket
    import sys

    for w in check_options(host=host, port=port, workdir=workdir, rig=rig):
        print(f"warning: {w}", file=sys.stderr, flush=True)
    if view == "server":
        from rigsim.environment import check_offscreen_gl

        check_offscreen_gl()
    try:  # a port in use: say so now, not as the web server's traceback
        with socket.socket(socket.AF_INET6 if ":" in host.strip("[]") else socket.AF_INET) as probe:
            probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            probe.bind((host.strip("[]"), port))
    except OSError as exc:
        raise ConfigError(f"cannot listen on {host}:{port}: {exc.strerror or exc}", field="--port",
                          allowed="a free port (e.g. --port 8081)") from None
    app = create_app(rigs_dir=rigs_dir, workdir=workdir, rig=rig, view=view, preview_width=preview_width)
    print(f"rigsim rig designer: http://{host}:{port}/  (folders: {app.sandbox.describe()})", flush=True)
    # timeout=0: serve until stopped (trame's default stops the server 300 s after the last page
    # disconnects, so a closed tab -- or any client that connects and leaves -- would end it)
    app.server.start(host=host, port=port, open_browser=open_browser, show_connection_info=False,
                     disable_logging=True, timeout=0)
