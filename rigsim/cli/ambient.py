"""``rigsim ambient``: the ambient light meter — daylight at depth (Ed, Eu, Eo, Eod, Eou, Lu, Kd ± errors)."""

from __future__ import annotations

import json

import typer

from rigsim.cli import app
from rigsim.errors import ConfigError


def _depths(text: str) -> list[float]:
    try:
        vals = [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        vals = []
    if not vals:
        raise ConfigError(f"cannot read depths {text!r}", field="--depths",
                          allowed="comma-separated depths in m, e.g. 1,5,10")
    return vals


#: Core field names → the options users typed, for one-line errors.
_OPTION_OF = {"bottom_reflectance": "--bottom-reflectance", "bottom_depth_m": "--bottom-depth",
              "depths": "--depths", "sun_zenith_deg": "--sun-zenith", "sky": "--sky",
              "sky_fraction": "--sky-fraction", "surface_irradiance": "--surface-irradiance",
              "wind_speed_m_s": "--wind", "photons": "--photons"}


@app.command("ambient")
def ambient(
    water: str = typer.Option(..., "--water", help="Preset (coastal, jerlov-II, …) or a water TOML file "
                                                   "(constituents or explicit a_per_m, b_per_m, phase, wavelength_nm)."),
    sun_zenith: float = typer.Option(..., "--sun-zenith", help="Sun zenith angle above the surface, deg [0, 90)."),
    sky: str = typer.Option("cie", "--sky", help="black | uniform | cie (CIE standard clear sky) | cie:N (type 1–15)."),
    depths: str = typer.Option("1,5,10", "--depths", help="Depths below the surface, m (0 = just below)."),
    bottom_depth: float = typer.Option(None, "--bottom-depth", help="Bottom depth, m (default: infinitely deep)."),
    bottom_reflectance: float = typer.Option(0.0, "--bottom-reflectance",
                                             help="Lambertian bottom reflectance in [0, 1] (0: black)."),
    surface_irradiance: float = typer.Option(
        None, "--surface-irradiance",
        help="Plane irradiance just above the surface, W/(m² nm), the same at every wavelength "
             "(default: ASTM G173 clear-sky model for this sun)."),
    sky_fraction: float = typer.Option(None, "--sky-fraction",
                                       help="Share of the surface irradiance from the sky, [0, 1] "
                                            "(default: the clear-sky model's; 0 with --sky black)."),
    wavelengths: str = typer.Option(None, "--wavelengths",
                                    help="START:STOP:STEP or a list, nm (default 400:700:50, or the water's "
                                         "posed wavelengths)."),
    wind: float = typer.Option(None, "--wind", help="Wind speed, m/s: Cox–Munk rough surface (default flat)."),
    model: str = typer.Option("monte-carlo", "--model", help="monte-carlo | kd (fast Kd shortcut)."),
    photons: int = typer.Option(None, "--photons", help="Photons per wavelength (default 100000)."),
    seed: int = typer.Option(0, "--seed", help="Random seed."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON object instead of tables."),
):
    """Daylight at depth: per wavelength and depth Ed, Eu, Eo, Eod, Eou (W/(m² nm)), Lu (W/(m² sr nm)) and Kd
    (1/m), each with its Monte Carlo standard error."""
    try:
        _ambient(water, sun_zenith, sky, depths, bottom_depth, bottom_reflectance, surface_irradiance,
                 sky_fraction, wavelengths, wind, model, photons, seed, as_json)
    except ConfigError as exc:
        if exc.field in _OPTION_OF and exc.file is None:
            raise ConfigError(exc.message, field=_OPTION_OF[exc.field], allowed=exc.allowed) from None
        raise


def _ambient(water, sun_zenith, sky, depths, bottom_depth, bottom_reflectance, surface_irradiance,
             sky_fraction, wavelengths, wind, model, photons, seed, as_json):
    import numpy as np

    from rigsim.config.water import load_water
    from rigsim.daylight import (
        DEFAULT_PHOTONS,
        Bottom,
        Surface,
        ambient_light_kd,
        ambient_light_monte_carlo,
        sky_model,
        surface_irradiance as make_above,
    )
    from rigsim.daylight.sky import BlackSky
    from rigsim.spectrum import parse_wavelength_range

    w = load_water(water)
    if wavelengths is not None:
        wl = parse_wavelength_range(wavelengths)
    elif getattr(w, "posed_wavelength_nm", None) is not None:
        wl = np.asarray(w.posed_wavelength_nm, float)
    else:
        wl = parse_wavelength_range("400:700:50")
    w.check_range(wl)
    sky_m = sky_model(sky, sun_zenith)
    bottom = Bottom(bottom_depth, bottom_reflectance) if bottom_depth is not None else Bottom(None, 0.0)
    if bottom_depth is None and bottom_reflectance != 0.0:
        raise ConfigError("--bottom-reflectance needs --bottom-depth", field="--bottom-reflectance")
    z = _depths(depths)
    surface = Surface(wind) if wind is not None else Surface()
    black = isinstance(sky_m, BlackSky)
    if black and sky_fraction not in (None, 0.0):
        raise ConfigError("a black sky has no sky light; --sky-fraction must be 0", field="--sky-fraction")
    above = make_above(wl, sun_zenith, sky_fraction=sky_fraction, total_W_per_m2_nm=surface_irradiance,
                       black_sky=black)
    kw = dict(sun_zenith_deg=sun_zenith, sky=sky_m, above=above, surface=surface, bottom=bottom)
    if model == "monte-carlo":
        n = DEFAULT_PHOTONS if photons is None else photons
        if n < 10:
            raise ConfigError(f"--photons must be >= 10, got {n}", field="--photons", allowed=">= 10")
        res = ambient_light_monte_carlo(w, wl, z, photons=n, seed=seed, **kw)
    elif model == "kd":
        res = ambient_light_kd(w, wl, z, **kw)
    else:
        raise ConfigError(f"unknown model {model!r}", field="--model", allowed="monte-carlo, kd")
    if as_json:
        typer.echo(json.dumps(res.to_json()))
        return
    _print_tables(res)


def _print_tables(res) -> None:
    from rich.console import Console
    from rich.table import Table

    from rigsim.daylight import QUANTITIES, UNITS

    con = Console()
    m = res.meta
    con.print(f"[bold]{m['water'].get('name', 'water')}[/bold] — sun {m['sun_zenith_deg']:g}°, sky {m['sky']}, "
              f"surface {m['surface']}, bottom {m['bottom']}; model {m['model']}"
              + (f", {m['photons_per_wavelength']} photons/λ, seed {m['seed']}" if m["model"] == "monte-carlo"
                 else f" ({m.get('kd_method')})"))
    con.print("Ed(0+) above the surface: " + ", ".join(
        f"{w:g} nm {e:.4g}" for w, e in zip(res.wavelength_nm, res.above.total)) + " W/(m² nm)")
    mc = m["model"] == "monte-carlo"
    for q in QUANTITIES:
        t = Table(title=f"{q} ({UNITS[q]})" + (" ± standard error" if mc else ""), title_justify="left")
        t.add_column("λ (nm)", justify="right")
        for z in res.depth_m:
            t.add_column(f"{z:g} m", justify="right")
        for j, w in enumerate(res.wavelength_nm):
            cells = [f"{res.values[q][i, j]:.4g} ± {res.stderr[q][i, j]:.2g}" if mc else f"{res.values[q][i, j]:.4g}"
                     for i in range(res.depth_m.size)]
            t.add_row(f"{w:g}", *cells)
        con.print(t)
