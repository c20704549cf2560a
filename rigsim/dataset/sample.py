"""Drawing one sample of a dataset and computing its image and ground truth.

Determinism: sample ``i`` of a dataset with seed ``S`` draws every parameter from
``numpy.random.default_rng([S, i])`` and renders and captures with seeds derived
from it, so it is the same image whichever worker computes it and in whatever order.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from pathlib import Path

import numpy as np

from rigsim.dataset.spec import DatasetSpec

__all__ = ["draw_sample", "compute_sample", "reflectance_library", "spec_categories"]


@functools.lru_cache(maxsize=None)
def reflectance_library(name: str) -> tuple[np.ndarray, np.ndarray, tuple[str, ...]]:
    """(wavelength_nm, reflectances (n, bands), labels) of a named spectral library (0…1).

    ``training``: the 190 reflectances of the RAW to ACES v1 training set shipped with
    colour-science (``colour.characterisation.read_training_data_rawtoaces_v1``, 380–780 nm);
    ``colorchecker``: the 24 ColorChecker patches (Ohta, colour-science);
    ``benthic``: coral sand and green, brown and red algae (Maritorena, Morel & Gentili 1994:
    :func:`rigsim.scene.reflectances.reflectance_benthic_Maritorena1994`).
    """
    import colour

    if name == "benthic":
        from rigsim.scene.reflectances import reflectance_benthic_Maritorena1994

        wl = np.arange(360.0, 831.0, 5.0)
        b = reflectance_benthic_Maritorena1994(wl)
        return wl, np.array(list(b.values())), tuple(b)
    if name == "training":
        msd = colour.characterisation.read_training_data_rawtoaces_v1()
        wl = np.asarray(msd.wavelengths, float)
        return wl, np.clip(np.asarray(msd.values, float).T, 0.0, 1.0), tuple(str(x) for x in msd.labels)
    from rigsim.scene.reflectances import reflectance_colorchecker_Ohta

    wl = np.arange(380.0, 781.0, 5.0)
    patches = reflectance_colorchecker_Ohta(wl)
    return wl, np.clip(np.array(list(patches.values())), 0, 1), tuple(patches)


def _uniform(rng, r):
    return float(rng.uniform(r[0], r[1])) if r[1] > r[0] else float(r[0])


def _loguniform(rng, r):
    return float(math.exp(rng.uniform(math.log(r[0]), math.log(r[1])))) if r[1] > r[0] else float(r[0])


def draw_sample(spec: DatasetSpec, index: int, seed: int) -> dict:
    """All random choices of sample ``index`` (JSON-serialisable)."""
    rng = np.random.default_rng([int(seed), int(index)])
    rec: dict = {"index": int(index), "seed": int(seed)}
    if spec.presets and rng.random() >= spec.constituent_probability:
        rec["water"] = {"preset": str(rng.choice(spec.presets))}
    else:
        rec["water"] = {"chl_mg_per_m3": _loguniform(rng, spec.chl_mg_per_m3),
                        "cdom_a440_per_m": _loguniform(rng, spec.cdom_a440_per_m),
                        "small_particles_ppm": _uniform(rng, spec.small_particles_ppm),
                        "large_particles_ppm": _uniform(rng, spec.large_particles_ppm)}
    rec["rig"] = str(rng.choice(spec.rigs))
    rec["power_fraction"] = _uniform(rng, spec.power_fraction)
    rec["sensor"] = str(rng.choice(spec.sensors))
    d = _uniform(rng, spec.distance_m)
    n = int(rng.integers(spec.objects[0], spec.objects[1] + 1))
    wl, lib, labels = reflectance_library(spec.reflectances)
    objects = []
    for k in range(n):
        kind = str(rng.choice(spec.kinds))
        obj = {"kind": kind, "distance_m": d * _uniform(rng, (0.85, 1.15)),
               "size_fraction": _uniform(rng, spec.size_fraction),
               # centre within the central 70 % of the frame (fractions of the half-width/height)
               "offset_frac": [float(rng.uniform(-0.7, 0.7)), float(rng.uniform(-0.7, 0.7))],
               "yaw_deg": float(rng.uniform(-35, 35)), "pitch_deg": float(rng.uniform(-25, 25)),
               "tilt_deg": float(rng.uniform(-20, 20)) if kind != "slanted-edge" else float(rng.uniform(3, 8))}
        if kind == "mesh":
            obj["mesh"] = str(rng.choice(spec.meshes))
        if kind in ("mesh", "white-disk", "black-disk"):
            j = int(rng.integers(len(labels)))
            obj["reflectance"] = {"library": spec.reflectances, "index": j, "label": labels[j]}
            if kind == "black-disk":
                obj["reflectance"]["scale"] = 0.1
        objects.append(obj)
    rec["objects"] = objects
    if rng.random() < spec.bottom_probability:
        rec["bottom_altitude_m"] = _uniform(rng, spec.bottom_altitude_m)
    rec["render_seed"] = int(rng.integers(0, 2**31 - 1))
    rec["noise_seed"] = int(rng.integers(0, 2**31 - 1))
    # marine snow: drawn last, so that a spec without it draws the samples it always did
    if spec.particle_probability > 0 and rng.random() < spec.particle_probability:
        rec["particles"] = {"level": str(rng.choice(spec.particle_levels)),
                            "seed": int(rng.integers(0, 2**31 - 1))}
    sb = spec.seabed
    if sb and rng.random() < sb["probability"]:  # (after the snow: the same rule)
        rec["seabed"] = _draw_seabed(sb, spec, rng)
        rec.pop("bottom_altitude_m", None)
    dl = spec.daylight
    if dl and rng.random() < dl["probability"]:
        rec["daylight"] = {"depth_m": _uniform(rng, dl["depth_m"]), "sun_zenith_deg": _uniform(rng, dl["sun_zenith_deg"]),
                           "sun_azimuth_deg": float(rng.uniform(0.0, 360.0))}
    return rec


def _draw_seabed(sb: dict, spec: DatasetSpec, rng) -> dict:
    """A seabed scene's choices: the height field, the rig's altitude and pitch, and where (pixel
    positions, fractions of the image) the objects, rocks and rubble rest, with their poses."""
    meshes = list(spec.meshes) or [_ROCK]
    wl, lib, labels = reflectance_library(sb.get("rock_reflectances", "benthic"))

    def placed(kind, size_m, mesh=None):
        j = int(rng.integers(len(labels)))
        o = {"kind": kind, "size_m": size_m, "at_px": [float(rng.uniform(0.08, 0.92)), float(rng.uniform(0.25, 0.95))],
             "yaw_deg": float(rng.uniform(-180, 180)), "pitch_deg": float(rng.uniform(-90, 90)),
             "tilt_deg": float(rng.uniform(-180, 180)), "bury": float(rng.uniform(0.1, 0.4))}
        if mesh:
            o["mesh"] = mesh
            o["reflectance"] = {"library": sb.get("rock_reflectances", "benthic"), "index": j, "label": labels[j]}
        return o

    rocks = [placed("mesh", _loguniform(rng, sb["rock_size_m"]), str(rng.choice(meshes)))
             for _ in range(int(rng.integers(sb["rocks"][0], sb["rocks"][1] + 1)))]
    rubble = [placed("mesh", _loguniform(rng, sb["rubble_size_m"]), str(rng.choice(meshes)))
              for _ in range(int(rng.integers(sb["rubble"][0], sb["rubble"][1] + 1)))]
    return {"field": {"seed": int(rng.integers(0, 2**31 - 1)), "extent_m": float(sb["extent_m"]),
                      "cells": int(sb["cells"]),
                      "ripple_wavelength_m": _uniform(rng, sb["ripple_wavelength_m"]),
                      "ripple_height_m": _uniform(rng, sb["ripple_height_m"]),
                      "ripple_direction_deg": float(rng.uniform(0, 180)),
                      "relief_m": _uniform(rng, sb["relief_m"]), "relief_scale_m": float(rng.uniform(1.5, 4.0)),
                      "slope_deg": _uniform(rng, sb["slope_deg"]),
                      "slope_direction_deg": float(rng.uniform(0, 360))},
            "altitude_m": _uniform(rng, sb["altitude_m"]), "camera_pitch_deg": _uniform(rng, sb["camera_pitch_deg"]),
            "rocks": rocks, "rubble": rubble}


_ROCK = str(Path(__file__).resolve().parents[2] / "data" / "meshes" / "rock.obj")


def spec_categories(spec: DatasetSpec) -> list[dict]:
    """The COCO categories of a spec's samples (:func:`rigsim.dataset.formats.categories_for`)."""
    from rigsim.dataset.formats import categories_for

    rocks = (list(spec.meshes) or [_ROCK]) if spec.seabed else []
    return categories_for(spec.kinds, spec.meshes, rocks)


def pitched_rig(rig, pitch_deg: float):
    """The rig turned ``pitch_deg`` down about its camera's right axis through the entrance pupil (camera
    and lights together, as a diver tilts the whole rig)."""
    right, _, _ = (np.asarray(a, float) for a in rig.camera.frame())
    pupil = np.asarray(rig.camera.position_m, float)
    a = math.radians(-pitch_deg)  # right = forward × up: a negative turn about it tips forward down
    K = np.array([[0, -right[2], right[1]], [right[2], 0, -right[0]], [-right[1], right[0], 0]])
    R = np.eye(3) + math.sin(a) * K + (1 - math.cos(a)) * K @ K  # Rodrigues
    t = lambda v: tuple(float(x) for x in v)  # noqa: E731
    cam = dataclasses.replace(rig.camera, forward=t(R @ np.asarray(rig.camera.forward, float)),
                              up=t(R @ np.asarray(rig.camera.up, float)))
    lights = tuple(dataclasses.replace(l, position_m=t(pupil + R @ (np.asarray(l.position_m, float) - pupil)),
                                       aim=t(R @ np.asarray(l.aim, float))) for l in rig.lights)
    return dataclasses.replace(rig, camera=cam, lights=lights)


def _seabed_targets(rec: dict, camera, spec: DatasetSpec) -> list:
    """The seabed target and the objects resting on it (targets in camera terms: distance along the axis
    and offset of their centres)."""
    from rigsim.scene.optics import WATER_INDEX, camera_rays
    from rigsim.scene.seabed import SeabedSpec, seabed_mesh_file, seabed_points
    from rigsim.scene.surfaces import target_surfaces
    from rigsim.scene.types import Target

    sb = rec["seabed"]
    field = SeabedSpec(**sb["field"])
    bed = Target(kind="seabed", distance_m=sb["altitude_m"], mesh_path=str(seabed_mesh_file(field)))
    surf = target_surfaces(bed, camera)[0]
    right, up, fwd = (np.asarray(a, float) for a in camera.frame())
    pupil = np.asarray(camera.position_m, float)
    world_up = np.array([0.0, 1.0, 0.0])
    # the drawn objects stand on the seabed where the pixel at their offset looks (charts and disks upright,
    # facing the camera as drawn); rocks and rubble lie in it, partly buried
    objects = [dict(o, at_px=[0.5 + 0.5 * o["offset_frac"][0], 0.5 - 0.5 * o["offset_frac"][1]], bury=-0.5 * 0.75,
                    size_m=None) for o in rec["objects"]]
    things = objects + list(sb["rocks"]) + list(sb["rubble"])
    out = [bed]
    if not things:
        return out
    px = np.array([o["at_px"] for o in things])
    o_, d_ = camera_rays(camera, px[:, 0], px[:, 1], n_outside=WATER_INDEX)
    hits = seabed_points(field, surf.matrix(), o_, d_)
    for o, p in zip(things, hits):
        if not np.all(np.isfinite(p)):
            continue  # (that pixel sees past the seabed: nothing placed there)
        size = o["size_m"]
        if size is None:  # a drawn object: its size a fraction of the field's width where it stands
            from rigsim.scene.optics import field_width_m

            size = o["size_fraction"] * field_width_m(camera, float((p - pupil) @ fwd))
        c = p + world_up * (0.5 - o["bury"]) * size
        rel = c - pupil
        refl_wl, refl = (), ()
        if "reflectance" in o:
            wl_o, lib_o, _ = reflectance_library(o["reflectance"]["library"])
            r = lib_o[o["reflectance"]["index"]] * o["reflectance"].get("scale", 1.0)
            refl_wl, refl = tuple(wl_o.tolist()), tuple(np.clip(r, 0, 1).tolist())
        out.append(Target(kind=o["kind"], distance_m=max(float(rel @ fwd), 1e-3), size_m=size,
                          mesh_path=o.get("mesh"), offset_m=(float(rel @ right), float(rel @ up)),
                          yaw_deg=o["yaw_deg"], pitch_deg=o["pitch_deg"], tilt_deg=o["tilt_deg"],
                          reflectance_wavelength_nm=refl_wl, reflectance=refl))
    return out


def _water(rec: dict):
    from rigsim.water import ConstituentWater, preset

    w = rec["water"]
    if "preset" in w:
        return preset(w["preset"])
    if w.get("vacuum"):
        from rigsim.water.model import Spectrum1D, TabulatedWater
        from rigsim.water.phase import HenyeyGreenstein

        return TabulatedWater("vacuum", Spectrum1D.constant(0.0), Spectrum1D.constant(0.0), HenyeyGreenstein(0.0),
                              source="a = b = 0 (consistency checks)")
    return ConstituentWater(name="drawn", **{k: v for k, v in w.items()})


def build_sample_scene(spec: DatasetSpec, rec: dict):
    """The Scene of a drawn sample."""
    from rigsim.config.rig import load_rig
    from rigsim.scene.optics import fov_water_deg
    from rigsim.scene.types import Scene, Target

    rig = load_rig(rec["rig"])
    pf = rec["power_fraction"]
    lights = tuple(dataclasses.replace(l, axial_intensity=tuple(float(x) * pf for x in l.axial_intensity))
                   for l in rig.lights)
    rig = dataclasses.replace(rig, lights=lights, camera=_cropped(rig.camera, spec.width, spec.height))
    water = _water(rec)
    if "seabed" in rec:
        rig = pitched_rig(rig, rec["seabed"]["camera_pitch_deg"])
    cam = rig.camera
    half_x = math.tan(math.radians(fov_water_deg(cam)) / 2)
    half_y = half_x * cam.sensor_height_mm / cam.sensor_width_mm
    wl_lib, lib, _ = reflectance_library(spec.reflectances)
    targets = []
    if "seabed" in rec:
        targets = _seabed_targets(rec, cam, spec)
    for o in ([] if "seabed" in rec else rec["objects"]):
        d = o["distance_m"]
        refl_wl, refl = (), ()
        if "reflectance" in o:
            r = lib[o["reflectance"]["index"]] * o["reflectance"].get("scale", 1.0)
            refl_wl, refl = tuple(wl_lib.tolist()), tuple(np.clip(r, 0, 1).tolist())
        kind = o["kind"]
        targets.append(Target(
            kind=kind, distance_m=d, size_m=o["size_fraction"] * 2 * d * half_x,
            mesh_path=o.get("mesh"), reflectance_wavelength_nm=refl_wl, reflectance=refl, tilt_deg=o["tilt_deg"],
            offset_m=(o["offset_frac"][0] * d * half_x, o["offset_frac"][1] * d * half_y),
            yaw_deg=o["yaw_deg"], pitch_deg=o["pitch_deg"]))
    if "bottom_altitude_m" in rec:
        targets.append(Target(kind="bottom", distance_m=rec["bottom_altitude_m"], size_m=200.0))
    seed = 0
    if rec.get("particles"):
        from rigsim.water.model import with_particles
        from rigsim.water.particles import particle_level

        water = with_particles(water, particle_level(rec["particles"]["level"]))
        seed = int(rec["particles"]["seed"])
    daylight = None
    if rec.get("daylight"):
        from rigsim.scene.types import Daylight

        daylight = Daylight(**rec["daylight"])
    return Scene(rig=rig, water=water, targets=tuple(targets), particle_seed=seed, daylight=daylight), water


def _cropped(camera, width: int, height: int):
    """The camera with its sensor cropped to the image's aspect (as a camera's 4:3 or 16:9 mode crops it),
    so that pixels are square; unchanged where the aspects agree."""
    sw, sh = camera.sensor_width_mm, camera.sensor_height_mm
    want = width / height
    if abs(want - sw / sh) < 1e-3 * want:
        return camera
    if want < sw / sh:
        return dataclasses.replace(camera, sensor_width_mm=sh * want)
    return dataclasses.replace(camera, sensor_height_mm=sw / want)


def _noise_free_linear(si, sensor, exposure, gains, ccm, layer=None) -> np.ndarray:
    """Linear sRGB of a (ground-truth) spectral layer through the sensor, without noise or mosaic:
    the same normalisation, white-balance gains and colour matrix as the developed image."""
    from rigsim.sensor.pipeline import mean_electrons_rgb

    if layer is not None:
        cont = si.layers.get(layer, np.zeros_like(si.radiance))
        fl = si.layers.get(f"flash_{layer}")
        si = dataclasses.replace(si, radiance=cont, layers={} if fl is None else {"flash": fl})
    e = mean_electrons_rgb(si, sensor, exposure).astype(np.float64)
    k = sensor.iso_setting(exposure.iso).gain_dn_per_e
    norm = e * k / (sensor.white_level_dn - sensor.black_level_dn) * np.asarray(gains, float)
    return norm @ np.asarray(ccm, float).T


def channel_attenuation(water, sensor, wavelength_nm, bandwidth_nm) -> np.ndarray:
    """Effective c (1/m) per camera channel: c(λ) averaged with the channel's QE × Δλ as weights."""
    qe = sensor.qe_at(wavelength_nm) * np.asarray(bandwidth_nm, float)[:, None]
    w = qe / qe.sum(axis=0, keepdims=True)
    c = water.c_per_m(np.asarray(wavelength_nm, float))
    return c @ w


def compute_sample(args: tuple[DatasetSpec, int, int, dict | None]) -> dict:
    """Render and capture sample ``index``; returns arrays and the record (see the writer)."""
    spec, index, seed, override = args
    import time

    from rigsim.render import render
    from rigsim.sensor import load_sensor
    from rigsim.sensor.noise import NoiseSwitches
    from rigsim.sensor.optics import lens_for
    from rigsim.sensor.pipeline import DevelopOptions, auto_exposure, capture
    from rigsim.sensor.white_balance import white_balance_gains

    t0 = time.perf_counter()
    rec = draw_sample(spec, index, seed)
    if override:
        rec.update(override)
    scene, water = build_sample_scene(spec, rec)
    snow = getattr(water, "particles", None) is not None
    layers = ("range_m", "object_id", "clear", "direct", "backscatter") + (("particles", "particle_id") if snow else ())
    if spec.engine == "fast":
        from rigsim.preview import render_preview

        si = render_preview(scene, width=spec.width, height=spec.height, seed=rec["render_seed"],
                            wavelengths_nm=spec.wavelengths_nm, layers=layers)
    else:
        si = render(scene, width=spec.width, height=spec.height, spp=spec.spp, seed=rec["render_seed"],
                    wavelengths_nm=spec.wavelengths_nm, layers=layers)
    sensor = load_sensor(rec["sensor"])
    lens = lens_for(si)
    exposure = auto_exposure(si, sensor, lens=lens)
    # The clean image: same view, lighting, housing (port, water index) and sensor with the water's
    # absorption and scattering removed.  One development for both images: white balance fixed
    # from the clean view.

    clean_cont = si.layers.get("clear", np.zeros_like(si.radiance))
    clean_flash = si.layers.get("flash_clear")
    clean_si = dataclasses.replace(si, radiance=clean_cont, layers={} if clean_flash is None else {"flash": clean_flash})
    clean_raw = capture(clean_si, sensor, exposure, seed=rec["noise_seed"], noise=NoiseSwitches.off(), develop=None)
    gains = white_balance_gains(clean_raw.half_rgb(), "grayworld")
    opts = DevelopOptions(white_balance="manual", wb_kwargs={"gains": gains.tolist()})
    noise = NoiseSwitches() if spec.noise else NoiseSwitches.off()
    under = capture(si, sensor, exposure, seed=rec["noise_seed"], noise=noise, develop=opts)
    clean = capture(clean_si, sensor, exposure, seed=rec["noise_seed"], noise=NoiseSwitches.off(), develop=opts)
    rng_m = np.asarray(si.layers["range_m"], np.float32)
    c_ch = channel_attenuation(water, sensor, si.wavelength_nm, si.bandwidth_nm)
    finite = np.isfinite(rng_m)
    trans = np.where(finite[..., None], np.exp(-np.where(finite, rng_m, 0)[..., None] * c_ch), 0.0).astype(np.float32)
    backscatter = _noise_free_linear(si, sensor, exposure, gains, under.ccm, layer="backscatter").astype(np.float32)
    direct = _noise_free_linear(si, sensor, exposure, gains, under.ccm, layer="direct").astype(np.float32)
    total = _noise_free_linear(si, sensor, exposure, gains, under.ccm).astype(np.float32)
    legend = si.meta.get("object_ids", {})
    extra = {}
    if snow:  # the particles' instance masks and their (net) light through the same processing
        from rigsim.metrics.scene import luminance
        from rigsim.metrics.specks import visible_specks

        extra["particle_id"] = np.asarray(si.layers["particle_id"], np.uint32)
        extra["particles_linear"] = _noise_free_linear(si, sensor, exposure, gains, under.ccm,
                                                       layer="particles").astype(np.float32)
        ref = float(np.median(luminance(np.asarray(under.linear_rgb, float))))
        extra["specks"] = visible_specks(luminance(extra["particles_linear"]), extra["particle_id"], ref).astype(np.uint32)
        rec["particles"] = {**rec["particles"], **{k: v for k, v in si.meta["particles"].items() if k != "field"},
                            "field": si.meta["particles"]["field"]}
    # the light that reached a surface after forward (small-angle) scattering on a leg: the rest of the
    # noise-free image once the unscattered light, the backscatter and the particles' own are taken out
    forward = total - direct - backscatter - extra.get("particles_linear", 0.0)
    from rigsim.dataset.formats import coco_annotations, depth_maps, instances, intrinsics, pose

    rng_m, z_m = depth_maps(rng_m, scene.camera)
    inst, inst_list = instances(si.layers["object_id"], legend, scene.targets)
    cats = spec_categories(spec)
    anns = coco_annotations(inst, inst_list, cats, index, extra.get("specks"), snow=spec.snow_labels)
    camera = {**intrinsics(scene.camera, spec.width, spec.height), **pose(scene.camera)}
    rec.update({
        "engine": spec.engine, "instances": inst_list,
        "water_description": water.describe(), "c_550_per_m": float(water.c_per_m(550.0)),
        "channel_attenuation_per_m": [float(x) for x in c_ch],
        "exposure": exposure.describe(), "wb_gains": [float(g) for g in gains],
        "ccm": np.asarray(under.ccm).tolist(), "object_ids": legend,
        "render": {"engine": spec.engine, "width": spec.width, "height": spec.height,
                   "spp": spec.spp if spec.engine == "mitsuba" else None,
                   "wavelengths_nm": list(spec.wavelengths_nm), "variant": si.meta.get("variant"),
                   "wall_time_s": si.meta.get("wall_time_s")},
    })
    rec["wall_time_s"] = time.perf_counter() - t0
    return {"record": rec, "image_srgb": under.srgb, "image_linear": np.asarray(under.linear_rgb, np.float32),
            "clean_srgb": clean.srgb, "clean_linear": np.asarray(clean.linear_rgb, np.float32),
            "range_m": rng_m, "z_m": z_m, "transmission": trans, "backscatter_linear": backscatter,
            "direct_linear": direct, "forward_linear": forward.astype(np.float32),
            "object_id": np.asarray(si.layers["object_id"], np.uint16), "instances": inst,
            "annotations": anns, "categories": cats, "camera": camera, "capture": under, **extra}
