"""``rigsim demo``: the main job of the README's first command."""

from __future__ import annotations

from pathlib import Path

import typer

from rigsim.cli import app


@app.command("demo")
def demo(out: Path = typer.Option(Path("out/demo"), "--out", help="Output folder."),
         quick: bool = typer.Option(False, "--quick", help="Smallest sizes (CI).")):
    """Run the demo: until the visibility study lands, the water-optics figure and IOP tables
    of the six original presets and four Jerlov types."""
    import json

    import numpy as np

    from rigsim.fileio import atomic_write_text
    from rigsim.report.water_plot import plot_waters
    from rigsim.water import preset

    names = ["pure-sea", "clear", "oceanic", "coastal", "coastal-regions", "lakes-and-rivers",
             "jerlov-IB", "jerlov-II", "jerlov-1C", "jerlov-5C"]
    waters = [preset(n) for n in names]
    out.mkdir(parents=True, exist_ok=True)
    fig = plot_waters(waters[:6], out / "water_presets.png")
    plot_waters(waters[6:], out / "water_jerlov.png")
    wl = np.arange(400.0, 701.0, 10.0)
    tables = {w.name: {k: v.tolist() for k, v in w.iop_table(wl).items()} for w in waters}
    atomic_write_text(out / "water_iops.json", json.dumps(tables, indent=1))
    typer.echo(f"report: {fig.resolve()}")
