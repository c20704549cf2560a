"""Scenes in metres: camera + lens + port, lights, targets, the water they sit in.

Pure data (frozen dataclasses), built by :mod:`rigsim.config` from rig files and
by :func:`rigsim.scene.build.build_scene` from a rig, a water, a target and a
distance.  Both renderers (:mod:`rigsim.render`, :mod:`rigsim.preview`) read the
same Scene.

Coordinates: right-handed, metres.  The camera's entrance pupil is at its
``position_m``; by default the camera looks along +z with +y up, so the image's
right is ``forward × up`` = world −x (as Mitsuba renders it).  Rig files give light
positions in the camera frame [right, up, forward].  Depth below the surface is a
separate scalar.
"""

from rigsim.scene.build import build_scene
from rigsim.scene.layout import target_layout
from rigsim.scene.surfaces import target_surfaces
from rigsim.scene.types import (
    BeamPattern,
    Camera,
    Daylight,
    Light,
    Port,
    Rig,
    Scene,
    Target,
)

__all__ = ["BeamPattern", "Camera", "Daylight", "Light", "Port", "Rig", "Scene", "Target", "build_scene",
           "target_layout", "target_surfaces"]
