"""``rigsim demo``: the main job of the README's first command."""

from __future__ import annotations

from pathlib import Path

import typer

from rigsim.cli import app

#: The demo study shipped with rigsim.
DEMO_STUDY = Path(__file__).resolve().parents[2] / "studies" / "demo.toml"


@app.command("demo")
def demo(out: Path = typer.Option(Path("out/demo"), "--out", help="Output folder."),
         quick: bool = typer.Option(False, "--quick", help="The study's small [quick] variant (CI)."),
         serial: bool = typer.Option(False, "--serial", help="Run without dask.")):
    """Run the demo study (strobes beside the port vs edge lighting, two sensors, four waters,
    six distances) and write its HTML report, plus the water-optics figure of the presets."""
    from rigsim.report.html import write_report
    from rigsim.report.water_plot import plot_waters
    from rigsim.study import load_study, run_study
    from rigsim.water import preset

    spec = load_study(DEMO_STUDY, quick=quick)
    run_study(spec, out, serial=serial)
    plot_waters([preset(n) for n in ("pure-sea", "clear", "coastal", "oceanic", "coastal-regions",
                                      "lakes-and-rivers", "jerlov-3C")], out / "water_presets.png")
    report = write_report(out)
    typer.echo(f"water optics figure: {(out / 'water_presets.png').resolve()}")
    typer.echo(f"report: {report.resolve()}")
