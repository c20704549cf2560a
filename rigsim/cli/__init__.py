"""The ``rigsim`` command line: thin typer commands over the package API (no physics here).

Each command group lives in its own module and registers itself on :data:`app`.
:func:`main` never shows a user a Python traceback:

* a usage error (unknown option, missing argument, a value of the wrong type) prints
  click's usage message (``Usage: ...`` and ``Error: No such option: --bogus``) and exits
  with status 2;
* an error rigsim raises on purpose (:class:`~rigsim.errors.RigsimError`) prints one line,
  ``error: <file>: <field>: <what> (allowed: ...)``, and exits with its ``exit_code``
  (2 for bad input, 1 for an output that cannot be written, 3 for a missing system
  library or a folder in use, 130 when interrupted);
* Ctrl-C (SIGINT) or SIGTERM stops with one line saying how to resume (exit 130);
* anything else is a bug: one line says what failed and where the full trace was written
  (:func:`crash_log_dir`, ``$RIGSIM_CACHE/logs`` or ``~/.cache/rigsim/logs``), exit 1.

``--log-level debug`` prints the traces as well.
"""

from __future__ import annotations

import datetime
import importlib
import logging
import os
import platform
import shlex
import signal
import sys
import traceback
import warnings
from contextlib import contextmanager
from pathlib import Path

import typer

from rigsim import __version__
from rigsim.errors import Interrupted, RigsimError

app = typer.Typer(name="rigsim", no_args_is_help=True, add_completion=False,
                  help="Underwater camera and lighting-rig design simulator.")

#: Modules that add commands to ``app`` (imported lazily by :func:`main`).
COMMAND_MODULES = ["rigsim.cli.water", "rigsim.cli.render", "rigsim.cli.sensor", "rigsim.cli.ambient", "rigsim.cli.study", "rigsim.cli.dataset", "rigsim.cli.designer", "rigsim.cli.optimise",
                   "rigsim.cli.demo"]

#: Levels accepted by ``--log-level``.
LOG_LEVELS = ("debug", "info", "warning", "error", "critical")
#: Crash logs kept in :func:`crash_log_dir` (the oldest are removed).
KEEP_CRASH_LOGS = 50
#: Exit status for an unexpected exception (a bug).
EXIT_INTERNAL = 1
#: Exit status when interrupted (128 + SIGINT, as a shell reports it).
EXIT_INTERRUPTED = 130


def _version(value: bool):
    if value:
        typer.echo(f"rigsim {__version__}")
        raise typer.Exit()


def _log_level(value: str) -> str:
    if value is None or str(value).lower() not in LOG_LEVELS:
        raise typer.BadParameter(f"{value!r} is not one of {', '.join(LOG_LEVELS)}")
    return str(value).lower()


@app.callback()
def _root(version: bool = typer.Option(False, "--version", callback=_version, is_eager=True,
                                       help="Print the version and exit."),
          log_level: str = typer.Option("warning", "--log-level", callback=_log_level,
                                        help="Logging level: debug (also prints tracebacks), info, warning, "
                                             "error, critical.")):
    level = getattr(logging, log_level.upper())
    logging.basicConfig(level=level, format="%(levelname)s %(name)s: %(message)s")
    logging.getLogger().setLevel(level)


def load_commands() -> typer.Typer:
    """Import every command module so that it registers on :data:`app`."""
    for mod in COMMAND_MODULES:
        importlib.import_module(mod)
    return app


def crash_log_dir() -> Path:
    """Where the full trace of an unexpected error is written: ``<cache>/logs``."""
    from rigsim.fileio import cache_dir

    return cache_dir() / "logs"


def _wants_debug(argv: list[str]) -> bool:
    """``--log-level debug`` (or ``=debug``) among the root options, read before parsing."""
    for i, a in enumerate(argv):
        if a == "--log-level" and i + 1 < len(argv):
            return argv[i + 1].lower() == "debug"
        if a.startswith("--log-level="):
            return a.split("=", 1)[1].lower() == "debug"
    return False


def _command_line(argv: list[str]) -> str:
    return shlex.join(["rigsim", *argv])


def write_crash_log(exc: BaseException, argv: list[str]) -> Path | None:
    """Write the trace of ``exc`` with what ran it to a new file in :func:`crash_log_dir`; its path.

    Returns None if no log could be written anywhere (then the trace goes to stderr)."""
    text = "".join([
        f"rigsim {__version__} crash log, {datetime.datetime.now().isoformat(timespec='seconds')}\n",
        f"command: {_command_line(argv)}\n",
        f"cwd: {os.getcwd()}\n",
        f"python {platform.python_version()} on {platform.platform()}\n",
        "".join(f"env {k}={os.environ[k]}\n" for k in sorted(os.environ)
                if k.startswith(("RIGSIM_", "DRJIT_"))),
        "\n",
        *traceback.format_exception(exc),
    ])
    stamp = datetime.datetime.now().strftime("%Y%m%d-%H%M%S")
    for folder in (crash_log_dir(), Path(os.environ.get("TMPDIR", "/tmp")) / "rigsim-logs"):
        try:
            folder.mkdir(parents=True, exist_ok=True)
            path = folder / f"rigsim-{stamp}-{os.getpid()}.log"
            path.write_text(text, encoding="utf-8")
        except OSError:
            continue
        try:  # keep the newest few
            old = sorted(folder.glob("rigsim-*.log"), key=lambda p: p.stat().st_mtime)[:-KEEP_CRASH_LOGS]
            for p in old:
                p.unlink(missing_ok=True)
        except OSError:
            pass
        return path
    return None


def _one_line(text: str) -> str:
    return " ".join(str(text).split())


@contextmanager
def _short_warnings(debug: bool):
    """Warnings as one line each (``warning: ...``), not the source line that raised them."""
    if debug:
        yield
        return
    old = warnings.showwarning

    def show(message, category, filename, lineno, file=None, line=None):
        try:
            print(f"warning: {_one_line(message)}", file=file or sys.stderr)
        except (OSError, ValueError):
            pass

    warnings.showwarning = show
    try:
        yield
    finally:
        warnings.showwarning = old


@contextmanager
def _sigterm_as_interrupt():
    """SIGTERM stops like Ctrl-C (clean stop, one line, resumable) while a command runs."""
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def handler(signum, frame):
        raise KeyboardInterrupt

    try:
        old = signal.signal(signal.SIGTERM, handler)
    except (ValueError, OSError):  # not the main thread of the main interpreter
        yield
        return
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, old)


def _click_exceptions() -> tuple[tuple[type, ...], tuple[type, ...], tuple[type, ...]]:
    """(ClickException, Exit, Abort) classes of typer's click and of click itself if installed."""
    import typer.exceptions as te
    from typer._click import exceptions as tce

    usage, exits, aborts = [tce.ClickException], [te.Exit], [te.Abort]
    try:
        import click.exceptions as ce

        usage.append(ce.ClickException)
        exits.append(ce.Exit)
        aborts.append(ce.Abort)
    except ImportError:  # pragma: no cover - click is optional
        pass
    return tuple(usage), tuple(exits), tuple(aborts)


def _say(text: str) -> None:
    try:
        print(text, file=sys.stderr, flush=True)
    except (OSError, ValueError):
        pass


def run_command(argv: list[str]) -> int:
    """Run the command line ``argv`` (without the program name); return the exit status.

    Never raises (except :class:`SystemExit` from code that calls ``sys.exit`` itself) and
    never prints a traceback unless ``--log-level debug`` is given.
    """
    debug = _wants_debug(argv)
    click_error, click_exit, click_abort = _click_exceptions()
    with _short_warnings(debug), _sigterm_as_interrupt():
        try:
            load_commands()
            cmd = typer.main.get_command(app)
            with cmd.make_context("rigsim", list(argv)) as ctx:
                rv = cmd.invoke(ctx)
            return rv if isinstance(rv, int) and not isinstance(rv, bool) else 0
        except click_exit as exc:
            return int(getattr(exc, "exit_code", 0) or 0)
        except click_error as exc:  # usage errors: click's own message, status 2
            exc.show()
            return int(getattr(exc, "exit_code", 2))
        except (KeyboardInterrupt, EOFError, *click_abort):
            if debug:
                traceback.print_exc()
            _say(f"interrupted; to resume, run the same command again: {_command_line(argv)}")
            return EXIT_INTERRUPTED
        except Interrupted as exc:  # a run stopped by a signal somewhere below
            if debug:
                traceback.print_exc()
            _say(f"interrupted ({_one_line(exc)}); to resume, run the same command again: {_command_line(argv)}")
            return EXIT_INTERRUPTED
        except RigsimError as exc:
            if debug:
                traceback.print_exc()
            _say(f"error: {_one_line(exc)}")
            return int(getattr(exc, "exit_code", 2))
        except BrokenPipeError:  # `rigsim water list | head -1`
            try:
                sys.stdout = open(os.devnull, "w")  # noqa: SIM115 - silence the flush at exit
            except OSError:
                pass
            return 1
        except MemoryError:
            log = write_crash_log(MemoryError("out of memory"), argv)
            _say(f"error: out of memory in `{_command_line(argv)}`" + (f" (trace: {log})" if log else ""))
            return EXIT_INTERNAL
        except SystemExit:
            raise
        except Exception as exc:  # noqa: BLE001 - the one place unexpected errors end
            log = write_crash_log(exc, argv)
            if debug:
                traceback.print_exc()
            what = f"{type(exc).__name__}: {_one_line(exc)}" if str(exc) else type(exc).__name__
            if len(what) > 300:
                what = what[:297] + "..."
            if isinstance(exc, OSError) and getattr(exc, "filename", None):
                head = f"error: {what}"
            else:
                head = f"internal error in `{_command_line(argv)}`: {what}"
            where = f"the full trace is in {log}" if log else "no log could be written"
            _say(f"{head} ({where}; --log-level debug prints it)")
            if log is None and not debug:
                traceback.print_exc()
            return EXIT_INTERNAL


def main(argv: list[str] | None = None) -> None:
    """Entry point of the ``rigsim`` script: :func:`run_command`, then exit with its status."""
    code = run_command(list(sys.argv[1:] if argv is None else argv))
    if code:
        sys.exit(code)
