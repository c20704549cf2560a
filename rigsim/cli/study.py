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
    check_study_folder(directory)
    typer.echo(f"report: {write_report(directory).resolve()}")


#: Columns the report reads from each table of a study folder.
_TABLE_COLUMNS = {"results.csv": ("rig", "sensor", "water", "target", "distance_m"),
                  "visibility.csv": ("rig", "sensor", "water", "target"), "timings.csv": ("case_id",)}
_REWRITE = "run `rigsim study` with the study's file and --out on this folder again: it rewrites the tables"


def check_study_folder(directory: Path) -> None:
    """A study folder's study.json and tables are readable as the report needs them, or one line why not."""
    import csv
    import json

    from rigsim.errors import ConfigError

    f = directory / "study.json"
    try:
        spec = json.loads(f.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise ConfigError(f"damaged: {' '.join(str(exc).split())}", file=f, allowed=_REWRITE) from None
    need = ("water_names", "rig_names", "sensors", "targets", "contrast_threshold", "render")
    if not isinstance(spec, dict) or any(k not in spec for k in need) or not isinstance(spec.get("render"), dict):
        raise ConfigError(f"damaged: not the study description rigsim writes (needs {', '.join(need)})", file=f,
                          allowed=_REWRITE)
    for name, cols in _TABLE_COLUMNS.items():
        t = directory / name
        if not t.is_file():
            continue
        try:
            rows = list(csv.reader(t.read_text(encoding="utf-8").splitlines()))
        except (OSError, ValueError, csv.Error) as exc:
            raise ConfigError(f"damaged: {' '.join(str(exc).split())}", file=t, allowed=_REWRITE) from None
        if not rows:
            continue
        header = rows[0]
        missing = [c for c in cols if c not in header] if len(rows) > 1 else []
        bad = next((i for i, r in enumerate(rows[1:], 2) if len(r) != len(header)), None)
        if missing or bad is not None:
            why = f"no column {missing[0]!r}" if missing else f"line {bad} has {len(rows[bad - 1])} fields, " \
                                                               f"the header {len(header)}"
            raise ConfigError(f"damaged: {why}", file=t, allowed=_REWRITE)
