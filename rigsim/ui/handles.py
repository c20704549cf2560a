"""Draggable light handles in the rig designer's 3-D view.

One VTK handle widget (a sphere) sits on each light's head.  Dragging it moves the
handle in the plane parallel to the screen through the light; when the mouse is
released, :class:`LightHandles` reports the light's index and new world position to
the app, which turns it into arm length, arm angle and forward offset in the camera
frame (:meth:`rigsim.config.rigdoc.RigDoc.move_light`), validates it like any other edit
(a light inside the housing is refused and its handle goes back) and updates the
preview.  Pressing on a handle selects that light.

A strobe arm swings in the plane across the lens axis, so by default the app keeps the
light's forward offset: the point used is where the line of sight through the handle
meets that plane (:func:`on_plane`), which is the same spot on the screen from any view.
With Shift held the light moves freely in the screen's plane.

The widgets live on the server's render-window interactor, so they work with the
server-rendered view (``view="server"``, the default): the browser forwards mouse
events to that interactor.  The client-rendered view (``view="client"``, vtk.js in the
browser) has no server interactor; lights are then moved with the sliders.
"""

from __future__ import annotations

from typing import Callable

import numpy as np

__all__ = ["LightHandles", "ensure_interactor", "on_plane", "HANDLE_COLOUR", "HANDLE_SELECTED_COLOUR",
           "HANDLE_SIZE_PX"]

#: Display colours (sRGB 0-1) of a handle, and of the selected light's handle.
HANDLE_COLOUR = (0.85, 0.85, 0.85)
HANDLE_SELECTED_COLOUR = (1.0, 0.55, 0.1)
#: Handle size on screen (pixels, VTK's handle size).
HANDLE_SIZE_PX = 22.0


def ensure_interactor(render_window):
    """The render window's interactor (trackball-camera style), created if it has none."""
    iren = render_window.GetInteractor()
    if iren is None:
        from vtkmodules.vtkRenderingCore import vtkRenderWindowInteractor

        iren = vtkRenderWindowInteractor()
        iren.SetRenderWindow(render_window)
        iren.GetInteractorStyle().SetCurrentStyleToTrackballCamera()
    return iren


def on_plane(eye_m, point_m, plane_point_m, normal, *, min_cos: float = 0.05):
    """Where the line of sight from ``eye_m`` through ``point_m`` meets a plane (m), or None when
    the line runs within ``asin(min_cos)`` of parallel to it or meets it behind the eye."""
    eye, point = np.asarray(eye_m, float), np.asarray(point_m, float)
    n = np.asarray(normal, float) / np.linalg.norm(normal)
    d = point - eye
    length = np.linalg.norm(d)
    if length == 0 or abs(np.dot(d, n)) < min_cos * length:
        return None
    s = np.dot(np.asarray(plane_point_m, float) - eye, n) / np.dot(d, n)
    return eye + s * d if s > 0 else None


class LightHandles:
    """Sphere handles on the lights, reporting drags.

    Parameters
    ----------
    renderer
        The VTK renderer of the 3-D view.
    interactor
        Its render-window interactor (:func:`ensure_interactor`).
    on_press
        ``on_press(index)``: a handle was grabbed.
    on_moved
        ``on_moved(index, world_position_m, free)``: a handle was released at a new position
        (``free``: Shift was held).
    on_drag
        ``on_drag(index, world_position_m, free)``: a handle is being dragged (every mouse move).
    """

    def __init__(self, renderer, interactor, *, on_press: Callable[[int], None],
                 on_moved: Callable[[int, np.ndarray, bool], None],
                 on_drag: Callable[[int, np.ndarray, bool], None] | None = None):
        self.renderer = renderer
        self.interactor = interactor
        self.on_press = on_press
        self.on_moved = on_moved
        self.on_drag = on_drag
        self._widgets: list = []  # (widget, representation)
        self.dragging: int | None = None  # index of the handle held by the mouse
        self._pressed_at: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self._widgets)

    def place(self, positions_m, selected: int | None = None) -> None:
        """One handle per light at its world position (m); the selected one in its colour."""
        positions = [np.asarray(p, float) for p in positions_m]
        while len(self._widgets) < len(positions):
            self._widgets.append(self._new(len(self._widgets)))
        while len(self._widgets) > len(positions):
            w, _ = self._widgets.pop()
            w.EnabledOff()
            w.SetInteractor(None)
        for i, (p, (w, rep)) in enumerate(zip(positions, self._widgets)):
            if i != self.dragging:  # a redraw while the mouse holds a handle leaves it there
                rep.SetWorldPosition([float(x) for x in p])
            rep.GetProperty().SetColor(*(HANDLE_SELECTED_COLOUR if i == selected else HANDLE_COLOUR))

    def world_positions(self) -> list[np.ndarray]:
        """Where the handles are now (m)."""
        return [np.asarray(rep.GetWorldPosition(), float) for _, rep in self._widgets]

    def _new(self, index: int):
        from vtkmodules.vtkInteractionWidgets import vtkHandleWidget, vtkSphereHandleRepresentation

        rep = vtkSphereHandleRepresentation()
        rep.SetHandleSize(HANDLE_SIZE_PX)
        rep.GetSelectedProperty().SetColor(1.0, 0.85, 0.2)
        w = vtkHandleWidget()
        w.SetInteractor(self.interactor)
        w.SetRepresentation(rep)
        w.SetCurrentRenderer(self.renderer)
        w.EnabledOn()
        w.AddObserver("StartInteractionEvent", lambda *_: self._pressed(index))
        w.AddObserver("EndInteractionEvent", lambda *_: self._released(index))
        w.AddObserver("InteractionEvent", lambda *_: self._dragged(index))
        return w, rep

    def _pressed(self, index: int) -> None:
        self.dragging = index
        self._pressed_at = np.asarray(self._widgets[index][1].GetWorldPosition(), float)
        self.on_press(index)

    def _dragged(self, index: int) -> None:
        if self.on_drag is not None:
            self.on_drag(index, np.asarray(self._widgets[index][1].GetWorldPosition(), float), self._shift())

    def _released(self, index: int) -> None:
        self.dragging = None
        now = np.asarray(self._widgets[index][1].GetWorldPosition(), float)
        if self._pressed_at is not None and np.allclose(now, self._pressed_at, atol=1e-6):
            return  # a click without a move
        self.on_moved(index, now, self._shift())

    def _shift(self) -> bool:
        return bool(self.interactor.GetShiftKey())
