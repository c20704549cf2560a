"""``rigsim water show|plot|list``: water optics tables and figures."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import typer

from rigsim.cli import app
from rigsim.config.water import load_water
from rigsim.spectrum import parse_wavelength_range

water_app = typer.Typer(no_args_is_help=True, help="Water optics: IOP tables, plots, presets.")
app.add_typer(water_app, name="water")

_OVERRIDE_HELP = "Override for constituent waters:"


@water_app.command("show")
def show(
    water: str = typer.Argument(..., help="Preset name (e.g. coastal, jerlov-II) or a water TOML file."),
    chl: float = typer.Option(None, "--chl", help=f"{_OVERRIDE_HELP} chlorophyll, mg/m³."),
    cdom: float = typer.Option(None, "--cdom", help=f"{_OVERRIDE_HELP} CDOM absorption at 440 nm, 1/m."),
    small: float = typer.Option(None, "--small", help=f"{_OVERRIDE_HELP} small particles, ppm."),
    large: float = typer.Option(None, "--large", help=f"{_OVERRIDE_HELP} large particles, ppm."),
    particles: str = typer.Option(None, "--particles",
                                  help="Discrete particles (marine snow): clear-ocean, coastal, plankton-bloom, "
                                       "silt-near-bottom, or none (default: the water's own)."),
    wavelengths: str = typer.Option("400:700:10", "--wavelengths", help="START:STOP:STEP or a list, nm."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON object instead of a table."),
):
    """Print the inherent optical properties a, b, c, b_b, albedo and Kd per wavelength, and the
    contribution of the water's discrete particles (marine snow), which is not part of them."""
    w = load_water(water, particles=particles, chl_mg_per_m3=chl, cdom_a440_per_m=cdom, small_particles_ppm=small,
                   large_particles_ppm=large)
    wl = parse_wavelength_range(wavelengths)
    w.check_range(wl)
    table = w.iop_table(wl)
    pf = w.particles
    ptab = None
    if pf is not None:
        ptab = {"a_per_m": pf.a_per_m(wl), "b_per_m": pf.b_per_m(wl), "c_per_m": np.full(len(wl), pf.c_per_m()),
                "bb_per_m": pf.bb_per_m(wl)}
    if as_json:
        out = {k: [float(x) for x in v] for k, v in table.items()}
        if pf is not None:
            out["particles"] = {**pf.describe(), **{k: [float(x) for x in v] for k, v in ptab.items()},
                                "note": "discrete particles, placed as objects by the renderers: not included in "
                                        "a_per_m, b_per_m, c_per_m, bb_per_m above"}
        typer.echo(json.dumps(out))
        return
    from rich.console import Console
    from rich.table import Table

    t = Table(title=f"water {w.name}: inherent optical properties")
    for col in ("λ (nm)", "a (1/m)", "b (1/m)", "c (1/m)", "b_b (1/m)", "albedo b/c", "Kd (1/m)"):
        t.add_column(col, justify="right")
    for i in range(len(wl)):
        t.add_row(f"{table['wavelength_nm'][i]:g}", *(f"{table[k][i]:.5g}" for k in
                                                      ("a_per_m", "b_per_m", "c_per_m", "bb_per_m", "albedo",
                                                       "kd_per_m")))
    Console().print(t)
    if pf is not None:
        what = f"level {pf.level!r}" if pf.level else "given by numbers"
        typer.echo(f"particles (marine snow, {what}): {pf.number_per_m3:.3g} per m³ of {pf.d_min_mm:g}–{pf.d_max_mm:g} mm "
                   f"(n(d) ∝ d^-{pf.size_slope:g}, mean {pf.mean_diameter_mm:.2g} mm), albedo {pf.albedo:g}; "
                   f"placed as objects, NOT included in the table above; their own c_p = {pf.c_per_m():.3g} 1/m, "
                   f"b_p = {float(ptab['b_per_m'].mean()):.3g} 1/m, b_bp = {float(ptab['bb_per_m'].mean()):.3g} 1/m, "
                   f"a_p = {float(ptab['a_per_m'].mean()):.3g} 1/m (mean over the wavelengths shown)")


@water_app.command("plot")
def plot(
    waters: list[str] = typer.Argument(..., help="Preset names or water TOML files."),
    out: Path = typer.Option(..., "--out", help="Output image (PNG, SVG, PDF)."),
):
    """Draw a, b, c spectra and the VSFs on log axes beside Petzold's measured VSFs."""
    from matplotlib.backend_bases import FigureCanvasBase

    from rigsim.errors import ConfigError
    from rigsim.report.water_plot import plot_waters

    kinds = sorted(FigureCanvasBase.get_supported_filetypes())
    suffix = out.suffix.lower().lstrip(".")
    if suffix not in kinds:
        raise ConfigError(f"cannot write a figure as {out.suffix or 'a file without a suffix'!r}", file=out,
                          field="--out", allowed="a file name ending in ." + ", .".join(kinds))
    path = plot_waters([load_water(w) for w in waters], out)
    typer.echo(f"wrote {path}")


@water_app.command("list")
def list_presets():
    """List the named water presets."""
    from rigsim.water.presets import WATER_PRESETS

    for name, desc in WATER_PRESETS.items():
        typer.echo(f"{name:18s} {desc}")
