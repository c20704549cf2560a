"""Errors that reach users as one clear line, never as a deep traceback.

Every error names *where* (file and field when there is one), *what* was wrong
and *what is allowed*.  The CLI prints ``str(error)`` and exits with the error's
:attr:`~RigsimError.exit_code` (2 for a user's mistake).
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable
from pathlib import Path


def one_line(text: str) -> str:
    """``text`` with line breaks and other control characters written as escapes (``\\n``, ``\\x1b``):
    an error names what a user wrote — a key, a file name — and may quote one that holds a newline,
    but is always printed as one line."""
    if text.isprintable():
        return text
    return "".join(ch if ch.isprintable() or ch == " " else repr(ch)[1:-1] for ch in text)


class RigsimError(Exception):
    """Base class of all errors rigsim raises on purpose."""

    #: Exit status of the command line for this error.
    exit_code = 2


class ConfigError(RigsimError, ValueError):
    """Invalid user input: a file, a field, a value or a name.

    Parameters
    ----------
    message
        What is wrong, e.g. ``"must be >= 0, got -1"``.
    file
        The file the value came from, if any.
    field
        Dotted path of the field, e.g. ``"water.chl_mg_per_m3"``.
    allowed
        A short description of the allowed values or range.
    """

    def __init__(self, message: str, *, file: str | Path | None = None,
                 field: str | None = None, allowed: str | None = None):
        self.message = message
        self.file = str(file) if file is not None else None
        self.field = field
        self.allowed = allowed
        where = ""
        if self.file and self.field:
            where = f"{self.file}: {self.field}: "
        elif self.file:
            where = f"{self.file}: "
        elif self.field:
            where = f"{self.field}: "
        tail = f" (allowed: {allowed})" if allowed else ""
        super().__init__(one_line(f"{where}{message}{tail}"))


class SpectrumRangeError(ConfigError):
    """A spectrum or table does not cover the wavelengths asked for."""


class DataError(RigsimError):
    """A data file shipped with rigsim is missing or malformed."""


class OutputError(RigsimError, OSError):
    """An output file or folder cannot be written (permissions, disk full, read-only file system).

    Also an :class:`OSError`, so code that handles I/O errors keeps working.  The files of
    the operation that failed are removed: nothing half-written is left behind.
    """

    exit_code = 1

    def __init__(self, path: str | Path, exc: BaseException | str):
        self.path = str(path)
        if isinstance(exc, OutputError):
            self.errno, what = exc.errno, exc.reason
        elif isinstance(exc, OSError):
            self.errno = exc.errno
            what = exc.strerror or str(exc)
        else:
            self.errno = None
            what = str(exc)
        self.reason = what
        RigsimError.__init__(self, one_line(f"{self.path}: cannot write: {what}"))

    def __str__(self) -> str:
        return self.args[0]


class EnvironmentProblem(RigsimError):
    """The machine lacks something rigsim needs (a usable libLLVM, EGL/OpenGL); says what to install."""

    exit_code = 3


class FolderInUse(RigsimError):
    """Another rigsim run holds the lock of an output folder."""

    exit_code = 3


class Interrupted(RigsimError):
    """A run was stopped (Ctrl-C, SIGTERM); what is finished is kept and the run can be resumed."""

    exit_code = 130


def unknown_name_error(kind: str, name: str, known: Iterable[str], *,
                       file: str | Path | None = None, field: str | None = None) -> ConfigError:
    """Build a ConfigError for an unknown name, suggesting the nearest known ones."""
    known = sorted(known)
    close = difflib.get_close_matches(name, known, n=3, cutoff=0.5)
    hint = f"; did you mean {', '.join(repr(c) for c in close)}?" if close else ""
    return ConfigError(f"unknown {kind} {name!r}{hint}", file=file, field=field,
                       allowed=", ".join(known))
