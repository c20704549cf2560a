"""``rigsim study FILE`` and ``rigsim report DIR``."""

from __future__ import annotations

from pathlib import Path

import typer

from rigsim.cli import app


@app.command("study")
def study(
    file: Path = typer.Argument(..., help="Study TOML file (see studies/)."),
    out: Path = typer.Option(None, "--out", help="Study folder (default: out/<study name>)."),
    scheduler: str = typer.Option(None, "--scheduler", help="Address of a dask scheduler (default: embedded local cluster)."),
    workers: int = typer.Option(None, "--workers", help="Worker processes of the embedded cluster."),
    serial: bool = typer.Option(False, "--serial", help="Run in this process without dask."),
    quick: bool = typer.Option(False, "--quick", help="Use the study's [quick] sizes (CI)."),
    no_report: bool = typer.Option(False, "--no-report", help="Do not write report.html."),
):
    """Run a study (resumes a previous run in the same folder) and write its report."""
    from rigsim.report.html import write_report
    from rigsim.study import load_study, run_study

    spec = load_study(file, quick=quick)
    out = out or Path("out") / (spec.name + ("-quick" if quick else ""))
    run_study(spec, out, scheduler=scheduler, workers=workers, serial=serial)
    typer.echo(f"results: {(out / 'results.csv').resolve()}")
    if not no_report:
        typer.echo(f"report: {write_report(out).resolve()}")


@app.command("report")
def report(directory: Path = typer.Argument(..., help="A study folder written by `rigsim study`.")):
    """(Re)write report.html of a study folder."""
    from rigsim.errors import ConfigError
    from rigsim.report.html import write_report

    if not (directory / "study.json").is_file():
        raise ConfigError("not a study folder (no study.json)", file=directory)
    typer.echo(f"report: {write_report(directory).resolve()}")
