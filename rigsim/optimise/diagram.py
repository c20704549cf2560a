"""A diagram of a lighting rig that a diver can read: where the arms go and where the lights point.

:func:`rig_diagram` draws one rig, or an optimised rig over its starting point, in two panels at
the same scale in metres:

* **top view** — seen from above: the camera's right across the page, its forward (the lens
  axis) up the page;
* **view from behind the camera** — as the diver holding the rig sees it: the image's right is
  the page's right, the camera's up is up the page.

Each panel shows the housing (the keep-out sphere of ``camera.housing_radius_m`` around the
entrance pupil), the port, every light's arm (a line from the housing centre to the light), the
light (a marker with its name), its aim, and the camera's field of view in water out to the
subject plane.  The top view adds each light's beam cone at half intensity as a translucent
wedge out to the subject plane, and the subject plane itself; the view from behind shows the
field's outline on the subject plane and, for each light, an arrow from the light to the point
where its beam axis meets that plane (⊗: aimed straight ahead, into the page).  The optimised
rig is in colour, the starting rig grey and dashed.  A table under the panels gives each light of
the optimised rig by name and colour: arm length, arm angle and forward offset, yaw and pitch (in
the rig file's conventions, :mod:`rigsim.config.rig`) and beam angle, with the starting value
beside each one that changed.

The geometry behind the picture is available on its own: :func:`camera_frame_geometry` (each
light in the camera frame, in the rig file's terms), :func:`beam_angle_half_intensity_deg`
and :func:`fov_water_xy_deg`.
"""

from __future__ import annotations

import io
import math
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from rigsim.config.rig import direction_to_yaw_pitch, position_to_arm, world_to_camera
from rigsim.fileio import atomic_write_bytes
from rigsim.scene.optics import WATER_INDEX, camera_rays, fov_water_deg
from rigsim.scene.types import BeamPattern, Camera, Rig

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

__all__ = ["LightGeometry", "to_camera_frame", "camera_frame_geometry", "beam_angle_half_intensity_deg",
           "fov_water_xy_deg", "draw_rig_diagram", "rig_diagram", "TOP_VIEW", "REAR_VIEW"]

#: Label (``Axes.get_label()``) of the top-view panel of :func:`draw_rig_diagram`.
TOP_VIEW = "top view"
#: Label of the panel seen from behind the camera.
REAR_VIEW = "view from behind the camera"

# Colours of the optimised rig's lights (blue is the camera's field, grey the starting rig).
_LIGHT_COLOURS = ("tab:orange", "tab:red", "tab:green", "tab:purple", "tab:brown", "tab:pink", "tab:olive")
_FIELD_COLOUR = "tab:blue"
_BEFORE_COLOUR = "0.45"
_N_EDGE = 48  # rays per side of the field's outline


@dataclass(frozen=True)
class LightGeometry:
    """One light of a rig in the camera frame, in the rig file's terms.

    Attributes
    ----------
    name, kind
        The light's name and kind (``"strobe"`` or ``"continuous"``).
    position_m
        Position ``(right, up, forward)`` relative to the entrance pupil (m).
    aim
        Unit beam axis ``(right, up, forward)``.
    arm_length_m
        Distance from the lens axis across it (m).
    arm_angle_deg
        Angle of the arm from the image's right towards its up, in [0, 360) (deg): 0 = right,
        90 = above, 180 = left, 270 = below.
    arm_forward_m
        Offset along the lens axis (m; negative = behind the entrance pupil).
    yaw_deg
        Turn of the beam axis from the lens axis towards the image's right, in (−180, 180] (deg).
    pitch_deg
        Turn of the beam axis up, in [−90, 90] (deg).
    beam_angle_deg
        Full beam angle at half intensity (deg; :func:`beam_angle_half_intensity_deg`).
    """

    name: str
    kind: str
    position_m: tuple[float, float, float]
    aim: tuple[float, float, float]
    arm_length_m: float
    arm_angle_deg: float
    arm_forward_m: float
    yaw_deg: float
    pitch_deg: float
    beam_angle_deg: float


def beam_angle_half_intensity_deg(beam: BeamPattern) -> float:
    """Full angle of a beam between its half-intensity edges (deg).

    Parameters
    ----------
    beam
        The beam pattern.

    Returns
    -------
    float
        ``kind="soft-cone"``: ``beam.beam_angle_deg``, at most 180° (the soft cone is dark beyond
        90° off its axis).  ``kind="table"``: twice the first angle at which ``relative`` falls to
        half its on-axis value (linear interpolation between rows, as the renderer reads the
        table); twice the last angle if it never does (the beam is dark beyond the table).

    Examples
    --------
    >>> beam_angle_half_intensity_deg(BeamPattern(kind="table", angle_deg=(0.0, 40.0, 80.0),
    ...                                           relative=(1.0, 0.8, 0.0)))
    110.0
    """
    if beam.kind == "soft-cone":
        return float(min(beam.beam_angle_deg, 180.0))
    a = np.asarray(beam.angle_deg, float)
    r = np.asarray(beam.relative, float)
    half = 0.5 * r[0]
    below = np.nonzero(r <= half)[0]
    if below.size == 0:
        return float(2.0 * a[-1])
    i = int(below[0])
    if i == 0:
        return 0.0
    a0, a1, r0, r1 = a[i - 1], a[i], r[i - 1], r[i]
    return float(2.0 * (a0 + (half - r0) * (a1 - a0) / (r1 - r0)))


def fov_water_xy_deg(camera: Camera, n_outside: float = WATER_INDEX) -> tuple[float, float]:
    """The camera's field of view outside the port, horizontal and vertical (deg, full angles).

    Parameters
    ----------
    camera
        Lens, sensor and port.
    n_outside
        Refractive index outside the port (sea water by default).

    Returns
    -------
    (horizontal, vertical)
        Full angles (deg) between the rays through the middles of opposite film edges, traced
        through the port (:func:`rigsim.scene.optics.camera_rays`): a dome keeps the in-air
        angles, a flat port narrows them by Snell's law.  The horizontal one is
        :func:`rigsim.scene.optics.fov_water_deg`.

    Examples
    --------
    >>> h, v = fov_water_xy_deg(Camera(focal_length_mm=24.0))  # dome: 2 atan(18/24), 2 atan(12/24)
    >>> round(h, 2), round(v, 2)
    (73.74, 53.13)
    """
    h = fov_water_deg(camera, n_outside)
    _, d = camera_rays(camera, np.array([0.5, 0.5]), np.array([0.0, 1.0]), n_outside=n_outside)
    v = float(np.degrees(np.arccos(np.clip(d[0] @ d[1], -1.0, 1.0))))
    return h, v


def camera_frame_geometry(rig: Rig) -> tuple[LightGeometry, ...]:
    """Every light of ``rig`` in the camera frame, in the rig file's terms (arm, yaw, pitch).

    Parameters
    ----------
    rig
        The rig; its lights are in world coordinates.

    Returns
    -------
    tuple of LightGeometry
        One per light, in the rig's order (empty for a rig without lights).  Arm and aim follow
        :func:`rigsim.config.rig.position_to_arm` and
        :func:`rigsim.config.rig.direction_to_yaw_pitch`, so a rig read from a file gives back
        the file's ``arm_length_m``, ``arm_angle_deg``, ``arm_forward_m``, ``yaw_deg`` and
        ``pitch_deg``.
    """
    out = []
    for light in rig.lights:
        p = world_to_camera(rig.camera, light.position_m)
        a = world_to_camera(rig.camera, light.aim, direction=True)
        a = a / np.linalg.norm(a)
        length, angle, forward = position_to_arm(p)
        yaw, pitch = direction_to_yaw_pitch(a)
        out.append(LightGeometry(name=light.name, kind=light.kind, position_m=tuple(float(v) for v in p),
                                 aim=tuple(float(v) for v in a), arm_length_m=length, arm_angle_deg=angle,
                                 arm_forward_m=forward, yaw_deg=yaw, pitch_deg=pitch,
                                 beam_angle_deg=beam_angle_half_intensity_deg(light.beam)))
    return tuple(out)


# ---------------------------------------------------------------------------- the geometry of one rig

@dataclass(frozen=True)
class _Layout:
    """What is drawn of one rig, in its camera frame (m)."""

    lights: tuple[LightGeometry, ...]
    camera: Camera
    fov_deg: tuple[float, float]
    wedge: np.ndarray  # (4, 2) top view: field's horizontal edges from the port to the subject plane
    outline: np.ndarray  # (n, 2) (right, up) of the field's border on the subject plane
    subject_half_width_m: float


def _to_plane(origin: np.ndarray, direction: np.ndarray, distance_m: float) -> np.ndarray:
    """Points where rays (camera frame) meet the plane ``forward = distance_m``."""
    t = (distance_m - origin[..., 2]) / direction[..., 2]
    return origin + direction * t[..., None]


def _layout(rig: Rig, distance_m: float, subject_width_m: float | None) -> _Layout:
    cam = rig.camera
    # Horizontal edges of the field (middle row), then the film's border, traced out of the port.
    o, d = camera_rays(cam, np.array([0.0, 1.0]), np.array([0.5, 0.5]), n_outside=WATER_INDEX)
    o, d = world_to_camera(cam, o), world_to_camera(cam, d, direction=True)
    far = _to_plane(o, d, distance_m)
    wedge = np.array([o[0, [0, 2]], far[0, [0, 2]], far[1, [0, 2]], o[1, [0, 2]]])
    s = np.linspace(0.0, 1.0, _N_EDGE)
    px = np.concatenate([s, np.ones_like(s), s[::-1], np.zeros_like(s)])
    py = np.concatenate([np.zeros_like(s), s, np.ones_like(s), s[::-1]])
    ob, db = camera_rays(cam, px, py, n_outside=WATER_INDEX)
    border = _to_plane(world_to_camera(cam, ob), world_to_camera(cam, db, direction=True), distance_m)
    half = 0.5 * subject_width_m if subject_width_m is not None else 0.5 * abs(far[1, 0] - far[0, 0])
    return _Layout(lights=camera_frame_geometry(rig), camera=cam, fov_deg=fov_water_xy_deg(cam), wedge=wedge,
                   outline=border[:, :2], subject_half_width_m=half)


def _beam_wedge(g: LightGeometry, distance_m: float, reach_m: float) -> np.ndarray | None:
    """Top-view polygon of a light's half-intensity cone, cut at the subject plane (or ``reach_m``).

    The cone is drawn in the page's plane around the beam axis projected onto it (exact for a
    level beam, pitch 0); None for a beam aimed straight up or down.
    """
    x, _, z = g.position_m
    ax, _, az = g.aim
    if math.hypot(ax, az) < 1e-9:
        return None
    phi = math.atan2(ax, az)
    half = math.radians(min(g.beam_angle_deg, 359.0) / 2)
    s = phi + np.linspace(-half, half, 91)
    ux, uz = np.sin(s), np.cos(s)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(uz > 1e-9, (distance_m - z) / uz, np.inf)
    t = np.where(t > 0, np.minimum(t, reach_m), reach_m)
    return np.vstack([[x, z], np.column_stack([x + t * ux, z + t * uz])])


# ---------------------------------------------------------------------------- drawing

def _style(after: bool) -> dict:
    return dict(ls="-" if after else "--", lw=1.6 if after else 1.2, alpha=1.0 if after else 0.9)


def _draw_camera(ax_top: Axes, ax_rear: Axes, lay: _Layout, distance_m: float, after: bool) -> None:
    from matplotlib.patches import Arc, Circle, Polygon, Rectangle

    st = _style(after)
    edge = "0.15" if after else _BEFORE_COLOUR
    field = _FIELD_COLOUR if after else _BEFORE_COLOUR
    cam = lay.camera
    rh = cam.housing_radius_m
    port = cam.port
    for ax in (ax_top, ax_rear):
        ax.add_patch(Circle((0, 0), rh, facecolor="0.92" if after else "none", edgecolor=edge, ls=st["ls"],
                            lw=st["lw"], zorder=3))
        ax.plot([0], [0], marker="+", color=edge, ms=8, zorder=4)
    # The port: a dome centred on the pupil, or a flat window at its standoff.
    if port.kind == "dome":
        r = port.radius_m + port.thickness_m
        ax_top.add_patch(Arc((0, 0), 2 * r, 2 * r, theta1=0, theta2=180, color=edge, lw=st["lw"] + 1.0,
                             ls=st["ls"], zorder=4))
    else:
        ax_top.add_patch(Rectangle((-port.radius_m, port.standoff_m), 2 * port.radius_m,
                                   max(port.thickness_m, 0.004), facecolor=edge, edgecolor=edge, zorder=4))
    ax_rear.add_patch(Circle((0, 0), port.radius_m, facecolor="none", edgecolor=edge, ls=st["ls"],
                             lw=st["lw"], zorder=4))
    # The field of view in water, to the subject plane; the subject plane.
    ax_top.add_patch(Polygon(lay.wedge, closed=True, facecolor=field if after else "none",
                             alpha=0.08 if after else 1.0, edgecolor="none", zorder=1))
    for i in (0, 3):
        j = 1 if i == 0 else 2
        ax_top.plot(lay.wedge[[i, j], 0], lay.wedge[[i, j], 1], color=field, ls=st["ls"], lw=1.0, zorder=2)
    h = lay.subject_half_width_m
    ax_top.plot([-h, h], [distance_m, distance_m], color="k" if after else _BEFORE_COLOUR, ls=st["ls"],
                lw=3.0 if after else 1.5, solid_capstyle="butt", zorder=5)
    ax_rear.add_patch(Polygon(lay.outline, closed=True, facecolor=field if after else "none",
                              alpha=0.06 if after else 1.0, edgecolor="none", zorder=1))
    ax_rear.plot(*np.vstack([lay.outline, lay.outline[:1]]).T, color=field, ls=st["ls"], lw=1.0, zorder=2)


def _outward(x: float, y: float) -> tuple[float, float]:
    n = math.hypot(x, y)
    return (1.0, 0.0) if n < 1e-9 else (x / n, y / n)


def _aim_point(g: LightGeometry, distance_m: float) -> tuple[tuple[float, float], bool]:
    """Rear view: where the beam axis meets the subject plane ``(right, up)`` (m) and True; for a
    light aimed sideways or back (or beyond the plane) a point a quarter of the distance along
    its projected axis, and False."""
    x, y, z = g.position_m
    ax_, ay_, az_ = g.aim
    if az_ > 1e-9 and z < distance_m:
        t = (distance_m - z) / az_
        return (x + t * ax_, y + t * ay_), True
    n = math.hypot(ax_, ay_) or 1.0
    return (x + 0.25 * distance_m * ax_ / n, y + 0.25 * distance_m * ay_ / n), False


def _draw_lights(ax_top: Axes, ax_rear: Axes, lay: _Layout, distance_m: float, reach_m: float,
                 after: bool, skip_names: frozenset[str] = frozenset()) -> None:
    """Draw the arms, lights, beam cones and aims of one rig (names in ``skip_names`` unlabelled)."""
    from matplotlib.patches import Polygon

    st = _style(after)
    arrow_top = 0.22 * distance_m
    for k, g in enumerate(lay.lights):
        col = _LIGHT_COLOURS[k % len(_LIGHT_COLOURS)] if after else _BEFORE_COLOUR
        x, y, z = g.position_m
        ax_, _, az_ = g.aim
        arrow = dict(arrowstyle="-|>", color=col, lw=st["lw"], ls=st["ls"], shrinkA=0, shrinkB=0,
                     mutation_scale=14 if after else 11)
        marker = dict(marker="o", ms=9, mfc=col if after else "white", mec="k" if after else col, mew=1.2,
                      zorder=8 if after else 7, ls="none")
        # Top view: arm, beam wedge, aim arrow, light.
        ax_top.plot([0, x], [0, z], color=col, ls=st["ls"], lw=st["lw"] + 1.0, zorder=6 if after else 5)
        poly = _beam_wedge(g, distance_m, reach_m)
        if poly is not None:
            if after:
                ax_top.add_patch(Polygon(poly, closed=True, facecolor=col, alpha=0.15, edgecolor="none", zorder=2))
                ax_top.plot(poly[[1, 0, -1], 0], poly[[1, 0, -1], 1], color=col, lw=0.8, alpha=0.8, zorder=2)
            else:
                ax_top.plot(poly[[1, 0, -1], 0], poly[[1, 0, -1], 1], color=col, lw=1.0, ls="--", zorder=3)
            n = math.hypot(ax_, az_)
            ax_top.annotate("", xy=(x + arrow_top * ax_ / n, z + arrow_top * az_ / n), xytext=(x, z),
                            arrowprops=arrow, zorder=7)
        ax_top.plot([x], [z], **marker)
        # Rear view: arm, light, where the beam axis meets the subject plane.
        ax_rear.plot([0, x], [0, y], color=col, ls=st["ls"], lw=st["lw"] + 1.0, zorder=6 if after else 5)
        (hx, hy), on_plane = _aim_point(g, distance_m)
        if math.hypot(hx - x, hy - y) > 0.01 * distance_m:
            ax_rear.annotate("", xy=(hx, hy), xytext=(x, y), arrowprops=arrow, zorder=7)
            if on_plane:
                ax_rear.plot([hx], [hy], marker="x", color=col, ms=8 if after else 6, mew=2.0 if after else 1.4,
                             zorder=7, ls="none")
            ax_rear.plot([x], [y], **marker)
        else:  # straight ahead, into the page
            ax_rear.plot([x], [y], marker="o", ms=13, mfc="white", mec=col, mew=1.6, zorder=marker["zorder"],
                         ls="none")
            ax_rear.plot([x], [y], marker="x", ms=8, color=col, mew=1.6, zorder=marker["zorder"] + 1, ls="none")
        if g.name in skip_names:
            continue
        ox, oy = _outward(x, y)
        tx = 1.0 if x >= 0 else -1.0
        text = dict(fontsize=9 if after else 8, color="k" if after else _BEFORE_COLOUR,
                    fontweight="bold" if after else "normal", style="normal" if after else "italic", zorder=10,
                    textcoords="offset points")
        if after:  # the starting rig's names only behind the camera: two rigs' names crowd the top view
            ax_top.annotate(g.name, xy=(x, z), xytext=(10 * tx, -12), ha="left" if tx > 0 else "right", va="top",
                            **text)
        ax_rear.annotate(g.name, xy=(x, y), xytext=(12 * ox, 12 * oy + (4 if oy >= 0 else -4)),
                         ha="left" if ox > 0.2 else ("right" if ox < -0.2 else "center"),
                         va="bottom" if oy >= 0 else "top", **text)


def _fmt(value: float, unit: str, fmt: str, old: float | None) -> str:
    s = f"{value:{fmt}}{unit}"
    if old is not None and f"{old:{fmt}}" != f"{value:{fmt}}":
        s += f"  ({old:{fmt}})"
    return s


def _draw_table(ax: Axes, lights: tuple[LightGeometry, ...], before: dict[str, LightGeometry] | None,
                label_before: str) -> None:
    """The optimised rig's lights in the rig file's terms, with the starting values where they differ."""
    ax.axis("off")
    cols = ["light", "arm length", "arm angle", "arm forward", "yaw", "pitch", "beam (½ int.)"]
    rows = []
    for g in lights:
        b = before.get(g.name) if before else None
        old = (lambda attr: getattr(b, attr) if b is not None else None)  # noqa: E731
        angle = old("arm_angle_deg")
        if angle is not None and g.arm_length_m > 1e-6:  # compare angles the short way round
            angle = g.arm_angle_deg + ((angle - g.arm_angle_deg + 180.0) % 360.0 - 180.0)
        rows.append([g.name + ("" if before is None or b is not None else "  (new)"),
                     _fmt(g.arm_length_m, " m", ".2f", old("arm_length_m")),
                     _fmt(g.arm_angle_deg, "°", ".0f", angle),
                     _fmt(g.arm_forward_m, " m", "+.2f", old("arm_forward_m")),
                     _fmt(g.yaw_deg, "°", "+.0f", old("yaw_deg")),
                     _fmt(g.pitch_deg, "°", "+.0f", old("pitch_deg")),
                     _fmt(g.beam_angle_deg, "°", ".0f", old("beam_angle_deg"))])
    table = ax.table(cellText=rows, colLabels=cols, loc="upper center", cellLoc="center",
                     bbox=[0.0, 0.0, 1.0, 1.0])
    table.auto_set_font_size(False)
    table.set_fontsize(9.5)
    for (r, c), cell in table.get_celld().items():
        cell.set_edgecolor("0.75")
        if r == 0:
            cell.set_text_props(fontweight="bold")
            cell.set_facecolor("0.93")
        elif c == 0:
            cell.set_facecolor(_LIGHT_COLOURS[(r - 1) % len(_LIGHT_COLOURS)])
            cell.set_alpha(0.45)
            cell.set_text_props(fontweight="bold")
    note = ("arm angle: 0° = image right, 90° = up, 180° = left;  arm forward: − = behind the entrance pupil;  "
            "yaw: + = towards image right;  pitch: + = up")
    if before is not None:
        note += f";  ({label_before} value) where it differs"
    ax.set_title(note, fontsize=8.5, loc="left", color="0.3")


def _limits(points, *, pad_frac: float = 0.08, pad_m: float = 0.05,
            top_extra: float = 0.0) -> tuple[tuple[float, float], tuple[float, float]]:
    pts = np.asarray(points, float)
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    pad = pad_frac * float(np.max(hi - lo)) + pad_m
    return (float(lo[0] - pad), float(hi[0] + pad)), (float(lo[1] - pad), float(hi[1] + pad + top_extra))


def draw_rig_diagram(after: Rig, before: Rig | None = None, *, distance_m: float,
                     subject_width_m: float | None = None, title: str = "",
                     labels: tuple[str, str] = ("optimised", "start")) -> Figure:
    """The diagram of :func:`rig_diagram` as a matplotlib figure (not saved).

    Parameters
    ----------
    after
        The rig drawn in colour, with its lights listed (the optimised one).
    before
        The rig drawn grey and dashed underneath (the starting point), or None.
    distance_m
        Distance of the subject plane ahead of the entrance pupil, along the lens axis (m, > 0).
    subject_width_m
        Width of the subject drawn on the subject plane (m, > 0); None: the width of the
        camera's field there.
    title
        Figure title; empty: the rigs' names.
    labels
        Legend names of ``after`` and ``before``.

    Returns
    -------
    matplotlib.figure.Figure
        On an Agg canvas, not registered with pyplot (nothing to close).  Its axes labelled
        :data:`TOP_VIEW` and :data:`REAR_VIEW` (``Axes.get_label()``) are in metres at equal
        aspect; their limits contain the housing, every light of both rigs and the subject (or
        field) width at ``distance_m`` (top view), and the field's outline on the subject plane
        and where the beam axes meet it (view from behind).  Below them, a table of the
        optimised rig's lights (arm length and angle, forward offset, yaw, pitch, beam angle).

    Raises
    ------
    ValueError
        ``distance_m`` or ``subject_width_m`` not finite and > 0.
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    if not (math.isfinite(distance_m) and distance_m > 0):
        raise ValueError(f"distance_m must be finite and > 0, got {distance_m!r}")
    if subject_width_m is not None and not (math.isfinite(subject_width_m) and subject_width_m > 0):
        raise ValueError(f"subject_width_m must be finite and > 0 (or None), got {subject_width_m!r}")
    lay_a = _layout(after, distance_m, subject_width_m)
    lay_b = _layout(before, distance_m, subject_width_m) if before is not None else None
    lays = [(lay_b, False)] if lay_b is not None else []
    lays.append((lay_a, True))

    # Limits first (they fix the panels' shapes): everything of both rigs.
    top_pts, rear_pts = [], []
    for lay, _ in lays:
        rh = lay.camera.housing_radius_m
        top_pts += [(-rh, -rh), (rh, rh), (-lay.subject_half_width_m, distance_m),
                    (lay.subject_half_width_m, distance_m)] + [tuple(p) for p in lay.wedge[[1, 2]]]
        rear_pts += [(-rh, -rh), (rh, rh)] + [tuple(p) for p in lay.outline]
        for g in lay.lights:
            top_pts.append((g.position_m[0], g.position_m[2]))
            rear_pts += [(g.position_m[0], g.position_m[1]), _aim_point(g, distance_m)[0]]
    top_x, top_y = _limits(top_pts, top_extra=0.06 * distance_m)
    rear_x, rear_y = _limits(rear_pts, pad_frac=0.1, top_extra=0.04 * distance_m)
    reach = 3.0 * max(distance_m, top_y[1] - top_y[0], top_x[1] - top_x[0])
    ratio_top = (top_x[1] - top_x[0]) / (top_y[1] - top_y[0])
    ratio_rear = (rear_x[1] - rear_x[0]) / (rear_y[1] - rear_y[0])

    # Size: 14 in wide, the panels as tall as their shapes need (at most 6.5 in), the table below.
    width = 14.0
    panel_h = min(6.5, 0.86 * width / (ratio_top + ratio_rear))
    table_h = 0.32 * (len(lay_a.lights) + 1) + 0.35 if lay_a.lights else 0.0
    legend_h = 0.9
    fig = Figure(figsize=(width, panel_h + table_h + legend_h + 1.1), layout="constrained")
    FigureCanvasAgg(fig)
    gs = fig.add_gridspec(2 if table_h else 1, 2, width_ratios=[ratio_top, ratio_rear],
                          height_ratios=[panel_h, table_h] if table_h else None)
    ax_top, ax_rear = fig.add_subplot(gs[0, 0]), fig.add_subplot(gs[0, 1])
    ax_top.set_label(TOP_VIEW)
    ax_rear.set_label(REAR_VIEW)

    names_a = frozenset(g.name for g in lay_a.lights)
    for lay, is_after in lays:
        _draw_camera(ax_top, ax_rear, lay, distance_m, is_after)
        _draw_lights(ax_top, ax_rear, lay, distance_m, reach, is_after,
                     skip_names=frozenset() if is_after else names_a)

    fh, fv = lay_a.fov_deg
    ax_top.set(xlim=top_x, ylim=top_y, xlabel="camera right (m) →", ylabel="forward, along the lens axis (m) →")
    ax_top.set_title("top view (from above: forward is up the page)", fontsize=11)
    ax_rear.set(xlim=rear_x, ylim=rear_y, xlabel="camera right (m) →", ylabel="camera up (m) →")
    ax_rear.set_title("view from behind the camera\n(as the diver sees it: page right = image right)",
                      fontsize=11)
    for ax in (ax_top, ax_rear):
        ax.set_aspect("equal", adjustable="box")
        ax.grid(True, color="0.88", lw=0.6, zorder=0)
        ax.set_axisbelow(True)
    h = lay_a.subject_half_width_m
    what = f"subject {2 * h:.2f} m wide" if subject_width_m is not None else f"field {2 * h:.2f} m wide"
    ax_top.annotate(f"subject plane at {distance_m:.2f} m ({what})", xy=(0.0, distance_m), xytext=(0, 5),
                    textcoords="offset points", ha="center", va="bottom", fontsize=9,
                    bbox=dict(boxstyle="round,pad=0.2", fc="white", ec="none", alpha=0.8), zorder=11)
    out = lay_a.outline
    ax_rear.annotate(f"field at {distance_m:.2f} m: {np.ptp(out[:, 0]):.2f} × {np.ptp(out[:, 1]):.2f} m",
                     xy=(float(out[:, 0].min()), float(out[:, 1].max())), xytext=(2, 3),
                     textcoords="offset points", ha="left", va="bottom", fontsize=9, color=_FIELD_COLOUR)
    if not lay_a.lights:
        ax_rear.annotate("no lights", xy=(0.5, 0.06), xycoords="axes fraction", ha="center", fontsize=10,
                         color="0.3")
    else:
        before_lights = {g.name: g for g in lay_b.lights} if lay_b is not None else None
        _draw_table(fig.add_subplot(gs[1, :]), lay_a.lights, before_lights, labels[1])

    names = f"{before.name} → {after.name}" if before is not None else after.name
    fig.suptitle(title or f"rig: {names}", fontsize=13)
    handles = [Line2D([], [], color="0.15", lw=2.6, marker="o", mfc="tab:orange", mec="k",
                      label=f"{labels[0]}: {after.name}")]
    if before is not None:
        handles.append(Line2D([], [], color=_BEFORE_COLOUR, lw=1.4, ls="--", marker="o", mfc="white",
                              label=f"{labels[1]}: {before.name}"))
    if any(lay.lights for lay, _ in lays):
        handles += [Patch(facecolor="tab:orange", alpha=0.3, label="beam cone to half intensity (per light colour)"),
                    Line2D([], [], color="0.15", marker="x", ls="none", ms=7, mew=2,
                           label="beam axis meets the subject plane"),
                    Line2D([], [], color="0.15", marker="$\\otimes$", ls="none", ms=11,
                           label="aimed straight ahead (into the page)")]
    handles += [Patch(facecolor=_FIELD_COLOUR, alpha=0.2, edgecolor=_FIELD_COLOUR,
                      label=f"camera field in water, {fh:.0f}° × {fv:.0f}°"),
                Patch(facecolor="0.92", edgecolor="0.15",
                      label=f"housing r {lay_a.camera.housing_radius_m:.2f} m, {lay_a.camera.port.kind} port "
                            f"r {lay_a.camera.port.radius_m:.2f} m")]
    fig.legend(handles=handles, loc="outside lower center", ncol=min(len(handles), 4), fontsize=9,
               frameon=False)
    return fig


def rig_diagram(after: Rig, before: Rig | None = None, *, distance_m: float, subject_width_m: float | None = None,
                out_png: str | Path, title: str = "", labels: tuple[str, str] = ("optimised", "start")) -> Path:
    """Draw a rig (and the rig it started from) for a diver and write the PNG.

    Two panels at one scale in metres (:mod:`rigsim.optimise.diagram`): the top view (camera
    right across, forward up the page) and the view from behind the camera (image right to the
    right, up up).  ``after`` is drawn in colour, its lights named and listed in a table below by
    arm length and angle, forward offset, yaw and pitch (camera frame, the rig file's conventions)
    with the starting values beside them; ``before`` grey and dashed.

    Parameters
    ----------
    after
        The rig to show (the optimised one).
    before
        The rig it started from, or None.
    distance_m
        Distance of the subject plane ahead of the entrance pupil (m, > 0): the beam cones and
        the camera's field of view in water are drawn out to it.
    subject_width_m
        Width of the subject on that plane (m); None: the field's width there.
    out_png
        The PNG to write (its folder is created; written atomically: a temporary file in the
        same folder, then renamed).
    title
        Figure title; empty: the rigs' names.
    labels
        Legend names of ``after`` and ``before``.

    Returns
    -------
    pathlib.Path
        ``out_png``.

    Raises
    ------
    ValueError
        ``distance_m`` or ``subject_width_m`` not finite and > 0.
    rigsim.errors.OutputError
        The folder or file cannot be written.

    Examples
    --------
    >>> from pathlib import Path
    >>> from tempfile import mkdtemp
    >>> from rigsim.config.rig import load_rig
    >>> rigs = Path(__file__).parents[2] / "rigs"
    >>> png = rig_diagram(load_rig(rigs / "twin-strobes-edge-lighting.toml"),
    ...                   load_rig(rigs / "twin-strobes-45-wide.toml"), distance_m=1.0,
    ...                   out_png=Path(mkdtemp()) / "rig.png")
    >>> png.stat().st_size > 10_000
    True
    """
    fig = draw_rig_diagram(after, before, distance_m=distance_m, subject_width_m=subject_width_m, title=title,
                           labels=labels)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    fig.clear()
    out = Path(out_png)
    atomic_write_bytes(out, buf.getvalue())
    return out
