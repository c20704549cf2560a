"""``rigsim optimise``: where a rig's strobes should go for a water and a subject distance."""

from __future__ import annotations

from pathlib import Path

import typer

from rigsim.cli import app


def _list(text: str, what: str, number: bool = False) -> list:
    from rigsim.errors import ConfigError

    items = [t.strip() for t in str(text).split(",") if t.strip()]
    if not items:
        raise ConfigError("is empty", field=what, allowed="one value or a comma-separated list")
    if not number:
        return items
    out = []
    for t in items:
        try:
            out.append(float(t))
        except ValueError:
            raise ConfigError(f"{t!r} is not a number", field=what, allowed="metres, e.g. 1.5 or 0.5,1,2") from None
    return out


@app.command("optimise")
def optimise_cmd(
    rig: Path = typer.Argument(..., help="Rig TOML file (see rigs/); its \\[limits] table bounds the search."),
    water: str = typer.Option(..., "--water", help="Water preset or TOML file; a comma-separated list sweeps."),
    distance: str = typer.Option(..., "--distance", help="Subject distance, m; a comma-separated list sweeps."),
    sensor: str = typer.Option("sony_ilce-7rm2", "--sensor", help="Sensor name (sensors/) or TOML file."),
    subject: str = typer.Option("colorchecker", "--subject", help="colorchecker | white-disk | path to an .obj|.ply|.gltf|.glb mesh (a rock, a coral head)"),
    fill: float = typer.Option(0.6, "--fill", help="The subject's width as a fraction of the frame's (0-1.5)."),
    particles: str = typer.Option("none", "--particles",
                                  help="Marine snow: none | clear-ocean | coastal | plankton-bloom | silt-near-bottom."),
    limits: str = typer.Option(None, "--limits",
                               help="Override the rig's limits, e.g. 'arm_length_m=0.3:0.8,yaw_out_deg=0:45,"
                                    "beam_angles_deg=80/110'."),
    weights: str = typer.Option(None, "--weights",
                                help="Score weights, e.g. 'backscatter=2,evenness=1,noise=1,colour=0.5,specks=1'."),
    independent: bool = typer.Option(False, "--independent",
                                     help="Move each light on its own (default: a pair of strobes mirrors)."),
    seed: int = typer.Option(0, "--seed", min=0, help="Seed of the search (same seed, same rig)."),
    check: bool = typer.Option(True, "--check/--no-check",
                               help="Verify the start and the optimum with Monte Carlo renders (about 30 s)."),
    quick: bool = typer.Option(False, "--quick",
                               help="A small search and 320-px photographs (seconds): for trying the command."),
    out: Path = typer.Option(..., "--out", help="Output folder."),
):
    """Search the strobes' arm lengths, angles, offsets, aims and beams for the best predicted photograph,
    and write the optimised rig file, before/after pictures, the numbers and what matters (DIR/report.html).
    With several waters or distances: the optimum for each, as DIR/sweep.html."""
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    from rigsim.config.rigdoc import RigDoc
    from rigsim.fileio import folder_lock, output_folder
    from rigsim.optimise.objective import Setting, parse_weights
    from rigsim.optimise.output import sentence, write_optimum
    from rigsim.optimise.search import optimise
    from rigsim.optimise.space import limits_for, parse_limits
    from rigsim.optimise.sweep import sweep_optimum, write_sweep

    waters = _list(water, "--water")
    distances = _list(distance, "--distance", number=True)
    doc = RigDoc.load(rig)
    lim = limits_for(doc, parse_limits(limits))
    w = parse_weights(weights)
    base = Setting(water=waters[0], distance_m=distances[0], sensor=sensor, subject=subject, subject_fill=fill,
                   particles=particles)
    for d in distances:
        Setting(distance_m=d)  # each distance checked before any work
    search = {"global_points": 16, "local_evaluations": 40} if quick else {}
    sym = False if independent else None
    with Progress(TextColumn("[bold]optimise[/bold] {task.description}"), BarColumn(),
                  TextColumn("{task.percentage:>3.0f}%"), TimeElapsedColumn()) as prog:
        task = prog.add_task("", total=1.0)
        tick = lambda f, m: prog.update(task, completed=f, description=m)  # noqa: E731
        if len(waters) * len(distances) > 1:
            out.mkdir(parents=True, exist_ok=True)
            with folder_lock(out):
                rows = sweep_optimum(doc, base, waters, distances, out, weights=w, limits=lim, symmetric=sym,
                                     seed=seed, progress=tick, **search)
                page = write_sweep(rows, out, rig_name=doc.name)
            prog.stop()
            from rigsim.optimise.sweep import water_sentence

            for wa in waters:
                typer.echo(water_sentence([r for r in rows if r["water"] == wa]))
            typer.echo(f"wrote {page.resolve()}")
            return
        with output_folder(out):
            opt = optimise(doc, base, weights=w, limits=lim, symmetric=sym, seed=seed,
                           progress=lambda f, m: tick(0.5 * f, m), **search)
            page = write_optimum(opt, out, check=check, photo_width=320 if quick else 960,
                                 progress=lambda f, m: tick(0.5 + 0.5 * f, m))
    typer.echo(sentence(opt))
    for n in opt.notes:
        typer.echo(f"note: {n}")
    typer.echo(f"wrote {page.resolve()} ({opt.evaluations} placements searched in {opt.seconds:.0f} s)")
