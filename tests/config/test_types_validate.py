"""Scene types validate themselves: an invalid one built from Python is refused with the
field and the allowed range, and the valid ones still behave as frozen dataclasses."""

from __future__ import annotations

import dataclasses
import pickle

import numpy as np
import pytest

from rigsim.errors import ConfigError
from rigsim.scene.types import BeamPattern, Camera, Daylight, Light, Port, Rig, Scene, Target

WL = (400.0, 550.0, 700.0)


def light(**kw) -> Light:
    args = dict(name="a", kind="strobe", position_m=(0.3, 0.0, 0.0), aim=(0.0, 0.0, 1.0), beam=BeamPattern(),
                wavelength_nm=WL, axial_intensity=(1.0, 2.0, 1.0))
    args.update(kw)
    return Light(**args)


def refused(build, *fragments) -> str:
    with pytest.raises(ConfigError) as e:
        build()
    msg = str(e.value)
    assert "\n" not in msg, msg
    for frag in fragments:
        assert frag in msg, msg
    return msg


@pytest.mark.parametrize("kw,fragments", [
    ({"axial_intensity": (1.0, -2.0, 1.0)}, ["Light.axial_intensity", ">= 0", "allowed:"]),
    ({"axial_intensity": (1.0, float("nan"), 1.0)}, ["Light.axial_intensity", "finite"]),
    ({"axial_intensity": (1.0, 2.0)}, ["Light.axial_intensity", "2 values for 3 wavelengths"]),
    ({"wavelength_nm": (400.0, 390.0, 700.0)}, ["Light.wavelength_nm", "increase strictly"]),
    ({"wavelength_nm": (), "axial_intensity": ()}, ["Light.wavelength_nm", "at least 1"]),
    ({"aim": (0.0, 0.0, 0.0)}, ["Light.aim", "zero vector", "allowed: [x, y, z]"]),
    ({"position_m": (0.0, float("inf"), 0.0)}, ["Light.position_m", "finite"]),
    ({"position_m": (0.0, 1.0)}, ["Light.position_m", "3 numbers"]),
    ({"kind": "video"}, ["Light.kind", "unknown kind 'video'", "allowed: continuous, strobe"]),
    ({"beam": "wide"}, ["Light.beam", "BeamPattern"]),
])
def test_invalid_light(kw, fragments):
    refused(lambda: light(**kw), *fragments)


def test_invalid_beam_and_port():
    refused(lambda: BeamPattern(beam_angle_deg=400.0), "BeamPattern.beam_angle_deg", "out of range: 400",
            "allowed: > 0 and < 360 (deg, full angle at half intensity)")
    refused(lambda: BeamPattern(edge_exponent=0.0), "BeamPattern.edge_exponent", "> 0 and <= 100")
    refused(lambda: BeamPattern(kind="table", angle_deg=(5.0, 40.0), relative=(1.0, 0.5)), "BeamPattern.angle_deg",
            "from 0")
    refused(lambda: Port(radius_m=-0.1), "Port.radius_m", "out of range: -0.1", "allowed: > 0 (m)")
    refused(lambda: Port(glass_index=0.9), "Port.glass_index", "allowed: >= 1")


@pytest.mark.parametrize("kw,fragments", [
    ({"f_number": 0.0}, ["Camera.f_number", "out of range: 0", "allowed: > 0"]),
    ({"focal_length_mm": -24.0}, ["Camera.focal_length_mm", "allowed: > 0 (mm)"]),
    ({"sensor_width_mm": float("nan")}, ["Camera.sensor_width_mm", "must be finite"]),
    ({"focus_distance_m": 0.0}, ["Camera.focus_distance_m", "allowed: > 0 (m)"]),
    ({"housing_radius_m": True}, ["Camera.housing_radius_m", "must be a number, got True"]),
    ({"up": (0.0, 0.0, 3.0)}, ["Camera.up", "parallel to forward"]),
    ({"forward": (0.0, 0.0, 0.0)}, ["Camera.forward", "zero vector"]),
    ({"focal_lenght_mm": 24.0}, ["Camera.focal_lenght_mm", "did you mean 'focal_length_mm'"]),
    ({"port": Port(radius_m=0.1), "f_number": "8"}, ["Camera.f_number", "must be a number, got '8'"]),
])
def test_invalid_camera(kw, fragments):
    refused(lambda: Camera(**kw), *fragments)


def test_nested_table_errors_name_the_path():
    refused(lambda: Camera(port={"kind": "fisheye"}), "Camera.port.kind", "unknown kind 'fisheye'")
    refused(lambda: Rig("r", Camera(), ({"name": "x"},)), "Rig.lights[0]")


@pytest.mark.parametrize("args,kw,fragments", [
    (("white-disk", -1.0), {}, ["Target.distance_m", "out of range: -1", "allowed: > 0 (m)"]),
    (("white-disk", 0.0), {}, ["Target.distance_m", "> 0"]),
    (("white-disk", 1.0), {"size_m": 0.0}, ["Target.size_m", "allowed: > 0 (m)"]),
    (("white-disc", 1.0), {}, ["Target.kind", "did you mean 'white-disk'"]),
    (("mesh", 1.0), {}, ["Target.mesh_path", "needs mesh_path"]),
    (("white-disk", 1.0), {"reflectance_wavelength_nm": (400.0, 700.0), "reflectance": (0.5,)},
     ["Target.reflectance", "1 values for 2 wavelengths"]),
    (("white-disk", 1.0), {"reflectance_wavelength_nm": (400.0, 700.0), "reflectance": (0.5, -0.1)},
     ["Target.reflectance", ">= 0"]),
    (("white-disk", float("nan")), {}, ["Target.distance_m", "finite"]),
])
def test_invalid_target(args, kw, fragments):
    refused(lambda: Target(*args, **kw), *fragments)


@pytest.mark.parametrize("kw,fragments", [
    ({"depth_m": -1.0}, ["Daylight.depth_m", "out of range: -1", "allowed: > 0 (m)"]),
    ({"depth_m": 5.0, "sun_zenith_deg": 90.0}, ["Daylight.sun_zenith_deg", "allowed: >= 0 and < 90 (deg)"]),
    ({"depth_m": 5.0, "sun_zenith_deg": -1.0}, ["Daylight.sun_zenith_deg", ">= 0"]),
    ({"depth_m": 5.0, "photons": 99}, ["Daylight.photons", "allowed: >= 100"]),
    ({"depth_m": 5.0, "photons": 1000.5}, ["Daylight.photons", "whole number"]),
    ({"depth_m": 5.0, "waves": "choppy"}, ["Daylight.waves", "unknown waves 'choppy'", "pierson-moskowitz"]),
    ({"depth_m": 5.0, "model": "sunny"}, ["Daylight.model", "allowed: kd, monte-carlo"]),
    ({"depth_m": 5.0, "sky": "cloudy"}, ["Daylight.sky", "unknown sky 'cloudy'"]),
    ({"depth_m": 5.0, "sky": "cie:20"}, ["Daylight.sky", "cie:1"]),
    ({"depth_m": 5.0, "wave_length_m": 0.0}, ["Daylight.wave_length_m", "> 0 (m)"]),
    ({"depth_m": 5.0, "surface_irradiance_wavelength_nm": (400.0,), "surface_irradiance": (1.0, 2.0)},
     ["Daylight.surface_irradiance", "2 values for 1 wavelengths"]),
    ({}, ["Daylight.depth_m", "missing required field"]),
])
def test_invalid_daylight(kw, fragments):
    refused(lambda: Daylight(**kw), *fragments)


def test_replace_validates_and_dataclass_behaviour_is_kept():
    lt = light()
    with pytest.raises(ConfigError, match=r"Light\.axial_intensity"):
        dataclasses.replace(lt, axial_intensity=(1.0, -1.0, 1.0))
    brighter = dataclasses.replace(lt, axial_intensity=tuple(2 * x for x in lt.axial_intensity))
    assert brighter.axial_intensity == (2.0, 4.0, 2.0) and brighter.beam == lt.beam
    with pytest.raises(dataclasses.FrozenInstanceError):
        lt.name = "b"  # type: ignore[misc]
    assert hash(lt) == hash(light()) and lt == light()
    assert pickle.loads(pickle.dumps(lt)) == lt
    d = dataclasses.asdict(Camera())
    assert d["port"]["kind"] == "dome" and Camera(**{**d, "port": Port(**d["port"])}) == Camera()
    assert lt.describe()["wavelength_range_nm"] == [400.0, 700.0]


def test_values_are_normalised():
    """Arrays, lists and numpy scalars become tuples of floats, so equality and hashing work."""
    lt = light(position_m=np.array([0.3, 0.0, 0.0]), aim=[0, 0, 1], wavelength_nm=np.array(WL),
               axial_intensity=np.float32(1.0) * np.ones(3))
    assert lt.position_m == (0.3, 0.0, 0.0) and lt.aim == (0.0, 0.0, 1.0)
    assert isinstance(lt.wavelength_nm, tuple) and all(type(x) is float for x in lt.axial_intensity)
    sc = Scene(Rig("r", Camera(), (lt,)), None, [Target("white-disk", 1.0)])
    assert isinstance(sc.targets, tuple)
    with pytest.raises(ConfigError, match=r"Scene\.water.*Water"):
        Scene(Rig("r", Camera()), "coastal", ())


def test_config_error_is_a_value_error():
    with pytest.raises(ValueError):
        Camera(f_number=-1.0)
