"""``rigsim render``: one scene → spectral image, preview and ground truth on disk."""

from __future__ import annotations

import json
from pathlib import Path

import typer

from rigsim.cli import app


def _parse_size(text: str) -> tuple[int, int]:
    from rigsim.errors import ConfigError

    try:
        w, h = (int(x) for x in text.lower().split("x"))
        if w < 1 or h < 1:
            raise ValueError
        return w, h
    except ValueError:
        raise ConfigError(f"cannot read size {text!r}", field="--size", allowed="WIDTHxHEIGHT, e.g. 256x192") from None


@app.command("render")
def render_cmd(
    rig: Path = typer.Argument(..., help="Rig TOML file (see rigs/)."),
    water: str = typer.Option(..., "--water", help="Water preset name or water TOML file."),
    particles: str = typer.Option(None, "--particles",
                                  help="Marine snow: clear-ocean | coastal | plankton-bloom | silt-near-bottom | none "
                                       "(default: the water file's own)."),
    particle_seed: int = typer.Option(0, "--particle-seed", min=0,
                                      help="Seed of the particles' placement (a scene input: every --seed sees them)."),
    distance: float = typer.Option(..., "--distance", help="Distance from the entrance pupil to the target, m."),
    target: str = typer.Option("colorchecker", "--target",
                               help="colorchecker | black-disk | white-disk | slanted-edge | bottom | MESH.obj/.ply"),
    target_size: float = typer.Option(None, "--target-size", help="Target size, m (default: its real size)."),
    size: str = typer.Option("256x192", "--size", help="Image size WIDTHxHEIGHT in pixels."),
    spp: int = typer.Option(64, "--spp", help="Paths per pixel (per batch with --noise-target)."),
    noise_target: float = typer.Option(None, "--noise-target",
                                       help="Render batches of --spp until the Monte Carlo noise (99th percentile "
                                            "of pixels, relative to the local mean) is below this, e.g. 0.2."),
    max_spp: int = typer.Option(None, "--max-spp", help="Most paths per pixel for --noise-target (default 8 × spp)."),
    seed: int = typer.Option(0, "--seed", help="Random seed."),
    wavelengths: str = typer.Option("400:700:10", "--wavelengths", help="Band centres START:STOP:STEP, nm."),
    split: bool = typer.Option(False, "--split", help="Also render the direct-only and backscatter-only layers."),
    engine: str = typer.Option("mitsuba", "--engine", help="mitsuba (Monte Carlo) or preview (semi-analytic)."),
    depth: float = typer.Option(None, "--depth", help="Camera depth below the surface, m (adds daylight)."),
    sun_zenith: float = typer.Option(30.0, "--sun-zenith", help="Sun zenith angle above the surface, deg."),
    daylight_model: str = typer.Option("kd", "--daylight-model",
                                       help="Daylight field at depth: kd (fast) or monte-carlo (the meter's)."),
    waves: str = typer.Option("flat", "--waves", help="Sea surface for caustics: flat | sines | pierson-moskowitz."),
    integrator: str = typer.Option("rigsim", "--integrator",
                                   help="rigsim (equiangular light sampling, default) or volpath (Mitsuba's)."),
    out: Path = typer.Option(..., "--out", help="Output folder."),
):
    """Render what the rig sees: DIR/spectral.exr (+ spectral.npz with every layer), preview.png,
    ground-truth layers (range_m.exr, object_id.png, clear.png) and meta.json."""
    from rigsim.config.rig import load_rig
    from rigsim.config.water import load_water
    from rigsim.errors import ConfigError
    from rigsim.fileio import output_folder
    from rigsim.scene.build import build_scene
    from rigsim.spectrum import parse_wavelength_range

    width, height = _parse_size(size)
    wl = parse_wavelength_range(wavelengths)
    if engine not in ("mitsuba", "preview"):
        raise ConfigError(f"unknown engine {engine!r}", field="--engine", allowed="mitsuba, preview")
    if integrator not in ("rigsim", "volpath"):
        raise ConfigError(f"unknown integrator {integrator!r}", field="--integrator", allowed="rigsim, volpath")
    daylight = None
    if depth is not None:
        from rigsim.scene.daylight_field import daylight_from_options

        daylight = daylight_from_options(depth, sun_zenith_deg=sun_zenith, model=daylight_model, waves=waves)
    scene = build_scene(load_rig(rig), load_water(water, particles=particles), target, distance, size_m=target_size,
                        daylight=daylight)
    if particle_seed:
        import dataclasses

        scene = dataclasses.replace(scene, particle_seed=particle_seed)
    with output_folder(out):  # a folder that cannot be written fails now, not after the render
        _render_into(out, scene, rig=rig, water=water, distance=distance, target=target, width=width,
                     height=height, spp=spp, noise_target=noise_target, max_spp=max_spp, seed=seed, wl=wl,
                     split=split, engine=engine, integrator=integrator, daylight=daylight, depth=depth,
                     sun_zenith=sun_zenith, daylight_model=daylight_model)


def _render_into(out: Path, scene, *, rig, water, distance, target, width, height, spp, noise_target, max_spp,
                 seed, wl, split, engine, integrator, daylight, depth, sun_zenith, daylight_model) -> None:
    from rich.progress import BarColumn, Progress, TextColumn, TimeRemainingColumn

    from rigsim.fileio import staged_output

    layers = ("range_m", "clear", "object_id")
    if getattr(scene.water, "particles", None) is not None:
        layers += ("particles", "particle_id")
    if engine == "preview":
        from rigsim.preview import render_preview

        si = render_preview(scene, width=width, height=height, wavelengths_nm=wl, layers=layers, split=split, seed=seed)
    else:
        from rigsim.render import render

        with Progress(TextColumn("[bold]render[/bold] {task.description}"), BarColumn(),
                      TextColumn("{task.percentage:>3.0f}%"), TimeRemainingColumn()) as prog:
            task = prog.add_task("", total=1.0)
            si = render(scene, width=width, height=height, spp=spp, seed=seed, wavelengths_nm=wl, layers=layers,
                        split=split, integrator=integrator, noise_target=noise_target, max_spp=max_spp,
                        progress=lambda f, msg: prog.update(task, completed=f, description=msg))
    with staged_output(out) as stage:  # every output or none (a full disk leaves the folder as it was)
        _write_outputs(stage, si, scene, rig=rig, water=water, distance=distance, target=target, width=width,
                       height=height, spp=spp, noise_target=noise_target, max_spp=max_spp, seed=seed, wl=wl,
                       split=split, engine=engine, integrator=integrator, depth=depth, sun_zenith=sun_zenith,
                       daylight_model=daylight_model)
    typer.echo(f"wrote {out.resolve()} (wall time {si.meta.get('wall_time_s', 0):.1f} s)")


def _write_outputs(out: Path, si, scene, *, rig, water, distance, target, width, height, spp, noise_target,
                   max_spp, seed, wl, split, engine, integrator, depth, sun_zenith, daylight_model) -> None:
    import io

    import imageio.v3 as iio
    import numpy as np

    from rigsim.fileio import atomic_write_bytes, atomic_write_text
    from rigsim.spectral_image import srgb_preview

    si.save(out)  # spectral.npz (radiance + every layer) and meta.json
    _write_exr(out / "spectral.exr", si)

    def png(arr) -> bytes:
        buf = io.BytesIO()
        iio.imwrite(buf, arr, extension=".png")
        return buf.getvalue()

    img, expo = srgb_preview(si)
    atomic_write_bytes(out / "preview.png", png(img))
    layer_files = {}
    if "clear" in si.layers or "flash_clear" in si.layers:
        clear, _ = srgb_preview(si, layer="clear", scale=expo["xyz_scale"])
        atomic_write_bytes(out / "clear.png", png(clear))
        layer_files["clear"] = "clear.png (same exposure as preview.png)"
    if "object_id" in si.layers:
        atomic_write_bytes(out / "object_id.png", png(np.asarray(si.layers["object_id"]).astype(np.uint16)))
        layer_files["object_id"] = "object_id.png (16-bit ids, legend in meta.json object_ids)"
    if "range_m" in si.layers:
        _write_exr(out / "range_m.exr", None, single=np.asarray(si.layers["range_m"], np.float32), name="range_m")
        layer_files["range_m"] = "range_m.exr (metres, inf where no surface)"
    meta = dict(si.meta)
    meta["inputs"] = {"rig": str(rig), "water": water, "distance_m": distance, "target": target,
                      "target_size_m": scene.targets[0].size_m, "width": width, "height": height, "spp": spp,
                      "noise_target": noise_target, "max_spp": max_spp,
                      "seed": seed, "engine": engine, "integrator": integrator, "split": split,
                      "depth_m": depth, "sun_zenith_deg": sun_zenith if depth is not None else None,
                      "daylight_model": daylight_model if depth is not None else None, "wavelengths_nm": wl.tolist()}
    meta["preview_png"] = expo
    meta["files"] = {"spectral.exr": "radiance bands, W/(m2 sr nm) (continuous light) and flash bands, "
                                     "J/(m2 sr nm) per flash",
                     "spectral.npz": "SpectralImage.load(): radiance, every layer, wavelengths", **layer_files}
    atomic_write_text(out / "meta.json", json.dumps(meta, indent=2, default=str))


def _write_exr(path: Path, si, *, single=None, name: str = "Y") -> None:
    """Multi-channel EXR through Mitsuba's Bitmap (channels named by band)."""
    import numpy as np

    from rigsim.fileio import atomic_write_bytes
    from rigsim.render.variant import mitsuba

    mi, _ = mitsuba()
    if single is not None:
        arr, names = single[..., None], [name]
    else:
        parts, names = [], []
        for key, arr_ in (("L", si.radiance), ("flash", si.layers.get("flash"))):
            if arr_ is None or (key == "L" and "flash" in si.layers and not np.any(arr_)):
                continue
            parts.append(np.asarray(arr_, np.float32))
            names += [f"{key}.{w:g}nm" for w in si.wavelength_nm]
        arr = np.concatenate(parts, axis=-1)
    bmp = mi.Bitmap(np.ascontiguousarray(arr, np.float32), channel_names=names)
    tmp = path.with_suffix(".tmp.exr")
    try:
        bmp.write(str(tmp))
        data = tmp.read_bytes()
    except Exception as exc:  # noqa: BLE001 - Mitsuba reports a full disk as RuntimeError
        from rigsim.errors import OutputError

        raise OutputError(path, exc if isinstance(exc, OSError) else " ".join(str(exc).split())) from exc
    finally:
        tmp.unlink(missing_ok=True)
    atomic_write_bytes(path, data)
