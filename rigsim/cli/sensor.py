"""``rigsim capture`` and ``rigsim develop``: thin commands over :mod:`rigsim.sensor`."""

from __future__ import annotations

from pathlib import Path

import typer

from rigsim.cli import app
from rigsim.errors import ConfigError

_WB_CLI = "grayworld, white_patch, chart (needs --wb-box), manual (needs --wb-gains), as_shot"


def _floats(text: str | None, n: int, name: str) -> list[float] | None:
    if text is None:
        return None
    try:
        vals = [float(v) for v in text.split(",")]
    except ValueError:
        vals = []
    if len(vals) != n:
        raise ConfigError(f"cannot read {text!r}", field=name, allowed=f"{n} comma-separated numbers")
    return vals


def _shutter(text: str) -> float:
    try:
        if "/" in text:
            a, b = text.split("/")
            return float(a) / float(b)
        return float(text)
    except (ValueError, ZeroDivisionError):
        raise ConfigError(f"cannot read shutter time {text!r}", field="--shutter",
                          allowed="seconds, e.g. 0.008 or 1/125") from None


def _develop_options(wb: str, wb_box: str | None, wb_gains: str | None, demosaic: str, gain: float):
    from rigsim.sensor import DevelopOptions

    kw = {}
    if wb == "chart":
        box = _floats(wb_box, 4, "--wb-box")
        if box is None:
            raise ConfigError("--wb chart needs --wb-box ROW0,ROW1,COL0,COL1", field="--wb-box",
                              allowed="pixel box of a neutral chart patch")
        kw["box"] = tuple(int(b) for b in box)
    elif wb == "manual":
        g = _floats(wb_gains, 3, "--wb-gains")
        if g is None:
            raise ConfigError("--wb manual needs --wb-gains R,G,B", field="--wb-gains", allowed="R,G,B > 0")
        kw["gains"] = g
    elif wb not in ("grayworld", "white_patch", "as_shot"):
        raise ConfigError(f"unknown white balance {wb!r}", field="--wb", allowed=_WB_CLI)
    return DevelopOptions(demosaic=demosaic, white_balance=wb, wb_kwargs=kw, gain=gain)


@app.command("capture")
def capture_cmd(
    render_dir: Path = typer.Argument(..., help="Render directory (spectral.npz + meta.json)."),
    sensor: str = typer.Option(..., "--sensor", help="Sensor name (see sensors/) or path to a sensor TOML."),
    out: Path = typer.Option(..., "--out", help="Output directory."),
    iso: float = typer.Option(None, "--iso", help="ISO (default: the sensor's base ISO)."),
    shutter: str = typer.Option(None, "--shutter", help="Shutter time in s (0.008 or 1/125)."),
    f_number: float = typer.Option(None, "--f-number",
                                   help="Lens f-number (default: the render's camera; stated in capture.json)."),
    transmittance: float = typer.Option(0.9, "--lens-transmittance", help="Lens transmittance (0-1]."),
    vignetting: bool = typer.Option(False, "--vignetting", help="cos^4 vignetting of the render's camera."),
    auto_exposure: bool = typer.Option(False, "--auto-exposure", help="Choose the shutter time automatically."),
    ae_percentile: float = typer.Option(99.0, "--ae-percentile", help="Auto-exposure: raw percentile to place."),
    ae_target: float = typer.Option(0.8, "--ae-target", help="Auto-exposure: fraction of saturation."),
    wb: str = typer.Option("grayworld", "--wb", help=f"White balance: {_WB_CLI}."),
    wb_box: str = typer.Option(None, "--wb-box", help="Neutral patch ROW0,ROW1,COL0,COL1 for --wb chart."),
    wb_gains: str = typer.Option(None, "--wb-gains", help="R,G,B gains for --wb manual."),
    demosaic: str = typer.Option("Malvar2004", "--demosaic", help="Demosaicing method."),
    seed: int = typer.Option(0, "--seed", help="Seed of the temporal noise."),
    fpn_seed: int = typer.Option(0, "--fpn-seed", help="Seed of the fixed-pattern noise (camera body)."),
    noise: str = typer.Option("all", "--noise", help="Noise terms on: all, none, or e.g. shot,read."),
    temperature: float = typer.Option(None, "--temperature", help="Sensor temperature (C)."),
    shape: str = typer.Option(None, "--shape", help="Mosaic ROWS,COLS (default: the render's; 'sensor')."),
    gain: float = typer.Option(1.0, "--gain", help="Digital gain before sRGB encoding."),
):
    """Photograph a render with a sensor: writes raw.dng, rgb.png, linear.tiff and capture.json."""
    from rigsim.sensor import Exposure, NoiseSwitches, load_sensor, save_capture
    from rigsim.sensor import auto_exposure as ae
    from rigsim.sensor import capture
    from rigsim.spectral_image import SpectralImage

    from rigsim.fileio import output_folder, staged_output

    s = load_sensor(sensor)
    si = SpectralImage.load(render_dir)
    from rigsim.sensor.optics import lens_for

    lens = lens_for(si, f_number=f_number, transmittance=transmittance, vignetting=vignetting)
    if auto_exposure == (shutter is not None):
        raise ConfigError("give exactly one of --shutter and --auto-exposure", field="--shutter",
                          allowed="--shutter S or --auto-exposure")
    if auto_exposure:
        exposure = ae(si, s, lens=lens, iso=iso, percentile=ae_percentile, target=ae_target,
                      temperature_c=temperature)
    else:
        exposure = Exposure(_shutter(shutter), s.base_iso if iso is None else iso, lens, temperature)
    if shape is None:
        shp = None
    elif shape == "sensor":
        shp = s.resolution
    else:
        shp = tuple(int(v) for v in _floats(shape, 2, "--shape"))
    opts = _develop_options(wb, wb_box, wb_gains, demosaic, gain)
    cap = capture(si, s, exposure, seed=seed, fpn_seed=fpn_seed, noise=NoiseSwitches.parse(noise),
                  shape=shp, develop=opts)
    with output_folder(out), staged_output(out) as stage:  # every output or none
        paths = save_capture(cap, stage, extra={"render_dir": str(render_dir)})
    typer.echo(f"{s.name}: t={exposure.exposure_time_s:.4g} s, ISO {exposure.iso:g}, f/{lens.f_number:g}; "
               f"wrote {', '.join(p.name for p in paths.values())} to {out}")


@app.command("develop")
def develop_cmd(
    photo: Path = typer.Argument(..., help="A raw file LibRaw reads (DNG, CR2, NEF, ARW ...)."),
    out: Path = typer.Option(None, "--out", help="Output directory (default: <photo stem>_developed)."),
    wb: str = typer.Option("as_shot", "--wb", help=f"White balance: {_WB_CLI}."),
    wb_box: str = typer.Option(None, "--wb-box", help="Neutral patch ROW0,ROW1,COL0,COL1 for --wb chart."),
    wb_gains: str = typer.Option(None, "--wb-gains", help="R,G,B gains for --wb manual."),
    demosaic: str = typer.Option("Malvar2004", "--demosaic", help="Demosaicing method."),
    gain: float = typer.Option(1.0, "--gain", help="Digital gain before sRGB encoding."),
):
    """Develop a real raw photo with the same processing as a simulated capture."""
    from rigsim.sensor import develop, read_raw, save_capture

    cap = develop(read_raw(photo), _develop_options(wb, wb_box, wb_gains, demosaic, gain))
    out = out or Path(f"{photo.stem}_developed")
    from rigsim.fileio import output_folder, staged_output

    with output_folder(out), staged_output(out) as stage:  # every output or none
        paths = save_capture(cap, stage, dng=False)
    typer.echo(f"{cap.camera}: wrote {', '.join(p.name for p in paths.values())} to {out}")


@app.command("sample-raw")
def sample_raw_cmd(
    name: str = typer.Argument("sony-ilce-7rm3", help="Which sample (see rigsim.sensor.samples)."),
):
    """Download (once) a real camera raw photo from a package registry and print its path.

    ``rigsim develop "$(rigsim sample-raw)"`` develops it with rigsim's pipeline.
    """
    from rigsim.sensor.samples import SAMPLE_RAWS, fetch_sample_raw

    path = fetch_sample_raw(name)
    typer.echo(str(path))
    typer.echo(f"{SAMPLE_RAWS[name].camera}; {SAMPLE_RAWS[name].licence}", err=True)
