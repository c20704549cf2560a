"""``rigsim dataset SPEC --n N --out DIR``: randomized training data with ground truth."""

from __future__ import annotations

from pathlib import Path

import typer

from rigsim.cli import app


@app.command("dataset")
def dataset(spec: Path = typer.Argument(..., help="Dataset spec TOML (see datasets/)."),
            n: int = typer.Option(..., "--n", help="Number of samples."),
            out: Path = typer.Option(..., "--out", help="Output folder (finished samples are kept and skipped)."),
            seed: int = typer.Option(0, "--seed", help="Dataset seed: sample i with seed S is always the same."),
            scheduler: str = typer.Option(None, "--scheduler", help="dask scheduler address (default: local cluster)."),
            workers: int = typer.Option(None, "--workers", help="Worker processes of the local cluster."),
            serial: bool = typer.Option(False, "--serial", help="Run in this process without dask.")):
    """Draw, render and capture N samples with ground truth (range, clean image, transmission,
    backscatter, mask, parameters) and write a manifest."""
    from rigsim.dataset import load_dataset_spec, run_dataset

    s = load_dataset_spec(spec)
    d = run_dataset(s, n, out, seed=seed, scheduler=scheduler, workers=workers, serial=serial)
    typer.echo(f"manifest: {(d / 'manifest.csv').resolve()}")
