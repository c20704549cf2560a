"""The ``rigsim`` command line: thin typer commands over the package API (no physics here).

Each command group lives in its own module and registers itself on :data:`app`.
Errors that rigsim raises on purpose (:class:`~rigsim.errors.RigsimError`) are
printed as one line and exit with status 2; anything else is a bug and keeps its
traceback.
"""

from __future__ import annotations

import importlib
import logging
import sys

import typer

from rigsim import __version__
from rigsim.errors import RigsimError

app = typer.Typer(name="rigsim", no_args_is_help=True, add_completion=False,
                  help="Underwater camera and lighting-rig design simulator.")

#: Modules that add commands to ``app`` (imported lazily by :func:`main`).
COMMAND_MODULES = ["rigsim.cli.water", "rigsim.cli.render", "rigsim.cli.sensor", "rigsim.cli.ambient", "rigsim.cli.study", "rigsim.cli.dataset", "rigsim.cli.designer",
                   "rigsim.cli.demo"]


def _version(value: bool):
    if value:
        typer.echo(f"rigsim {__version__}")
        raise typer.Exit()


@app.callback()
def _root(version: bool = typer.Option(False, "--version", callback=_version, is_eager=True,
                                       help="Print the version and exit."),
          log_level: str = typer.Option("WARNING", "--log-level", help="Logging level.")):
    logging.basicConfig(level=log_level.upper(), format="%(levelname)s %(name)s: %(message)s")


def load_commands() -> typer.Typer:
    """Import every command module so that it registers on :data:`app`."""
    for mod in COMMAND_MODULES:
        importlib.import_module(mod)
    return app


def main(argv: list[str] | None = None) -> None:
    """Entry point of the ``rigsim`` script."""
    load_commands()
    try:
        app(args=argv, standalone_mode=False)
    except RigsimError as exc:
        typer.echo(f"error: {exc}", err=True)
        sys.exit(2)
    except (typer.Exit, SystemExit) as exc:  # typer's own exits
        code = getattr(exc, "exit_code", getattr(exc, "code", 0))
        sys.exit(code or 0)
    except Exception as exc:  # click usage errors
        import click

        if isinstance(exc, click.ClickException):
            exc.show()
            sys.exit(exc.exit_code)
        if isinstance(exc, click.exceptions.Abort):
            sys.exit(130)
        raise
