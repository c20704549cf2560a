"""The folders the rig designer may read and write.

The app is a web server: whatever a browser sends as a file name is untrusted.
:class:`FileSandbox` accepts only ``.toml`` files inside its folders — the
repository's ``rigs/`` and one folder the user chose with ``--workdir`` — after
resolving ``..`` and symbolic links (URL-encoded names such as ``..%2f`` and backslashes
are refused outright), and refuses everything else with one line
(:class:`~rigsim.errors.ConfigError`) that the UI shows.

Examples
--------
>>> import tempfile
>>> box = FileSandbox({"work": tempfile.mkdtemp()})
>>> box.resolve("../../etc/x.toml", folder="work")
Traceback (most recent call last):
...
rigsim.errors.ConfigError: ../../etc/x.toml: refused: outside the folders this app may use (allowed: work: ...)
"""

from __future__ import annotations

import os
import re
from pathlib import Path

from rigsim.errors import ConfigError
from rigsim.fileio import atomic_write_text

__all__ = ["FileSandbox", "default_rigs_dir"]

_MAX_NAME = 255
#: A percent-encoded byte (``%2f``, ``%2E``).
_ENCODED = re.compile(r"%[0-9A-Fa-f]{2}")


def default_rigs_dir() -> Path:
    """The repository's ``rigs/`` folder (next to the ``rigsim`` package)."""
    return Path(__file__).resolve().parents[2] / "rigs"


class FileSandbox:
    """Named folders; file names are resolved inside them or refused.

    Parameters
    ----------
    folders
        ``{label: path}``, e.g. ``{"rigs": ".../rigs", "work": "~/dives"}``; labels are
        what the UI shows.  Folders that do not exist are created only by :meth:`write_text`
        (never their parents outside the sandbox: the folder itself must be given).
    """

    def __init__(self, folders: dict[str, str | Path]):
        if not folders:
            raise ConfigError("at least one folder is needed", field="folders")
        self.folders: dict[str, Path] = {}
        for label, p in folders.items():
            self.folders[str(label)] = Path(os.path.realpath(Path(p).expanduser()))

    def describe(self) -> str:
        return ", ".join(f"{k}: {v}" for k, v in self.folders.items())

    def _inside(self, p: Path) -> bool:
        return any(p == root or root in p.parents for root in self.folders.values())

    def resolve(self, name: str, *, folder: str | None = None) -> Path:
        """The real path of ``name`` if it is a ``.toml`` file inside one of the folders.

        Parameters
        ----------
        name
            A file name, a path relative to ``folder``, or an absolute path.
        folder
            Label of the folder relative names are taken in (default: the first).

        Raises
        ------
        ConfigError
            Empty or over-long names, control characters, another suffix than
            ``.toml``, or a path that ends up (after ``..`` and symbolic links)
            outside every folder.
        """
        text = "" if name is None else str(name).strip()
        if not text:
            raise ConfigError("no file name given", field="file", allowed="a name ending in .toml")
        if len(text) > 4 * _MAX_NAME or any(ord(c) < 32 or c == "\x7f" for c in text):
            raise ConfigError("refused: not a usable file name", file=text[:80], allowed="a name ending in .toml")
        if _ENCODED.search(text) or "\\" in text:
            # a browser or a script may send "..%2f.." or "..\\..": refused rather than saved under an odd name
            raise ConfigError("refused: URL-encoded or backslash names are not accepted", file=text[:80],
                              allowed="a plain name ending in .toml")
        label = folder if folder is not None else next(iter(self.folders))
        if label not in self.folders:
            raise ConfigError(f"unknown folder {label!r}", field="folder", allowed=", ".join(self.folders))
        raw = Path(text).expanduser() if text.startswith("~") else Path(text)
        candidate = raw if raw.is_absolute() else self.folders[label] / raw
        real = Path(os.path.realpath(candidate))
        if not self._inside(real) or real in self.folders.values():
            raise ConfigError("refused: outside the folders this app may use", file=text,
                              allowed=self.describe())
        if real.suffix.lower() != ".toml" or len(real.name) > _MAX_NAME:
            raise ConfigError("refused: only .toml rig files are read and written", file=text,
                              allowed="a name ending in .toml")
        return real

    def read_text(self, name: str, *, folder: str | None = None) -> tuple[Path, str]:
        """Read a file inside the sandbox (``ConfigError`` if refused or missing)."""
        p = self.resolve(name, folder=folder)
        if not p.is_file():
            raise ConfigError("file not found", file=p)
        try:
            return p, p.read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError) as exc:
            raise ConfigError(f"cannot read: {exc}", file=p) from None

    def write_text(self, name: str, text: str, *, folder: str | None = None, overwrite: bool = False) -> Path:
        """Write a file inside the sandbox atomically; an existing file only with ``overwrite``."""
        p = self.resolve(name, folder=folder)
        if p.exists() and not overwrite:
            raise ConfigError("exists already (tick 'overwrite' to replace it)", file=p)
        if not p.parent.is_dir():
            if p.parent in self.folders.values():
                p.parent.mkdir(parents=False, exist_ok=True)
            else:
                raise ConfigError("folder does not exist", file=p.parent)
        try:
            atomic_write_text(p, text)
        except OSError as exc:
            raise ConfigError(f"cannot write: {exc.strerror or exc}", file=p) from None
        return p

    def list_files(self) -> list[dict]:
        """The ``.toml`` files of every folder: ``[{"folder", "name", "path"}]`` sorted by folder then name."""
        out = []
        for label, root in self.folders.items():
            if not root.is_dir():
                continue
            for p in sorted(root.glob("*.toml")):
                real = Path(os.path.realpath(p))
                if self._inside(real) and real.is_file():
                    out.append({"folder": label, "name": p.name, "path": str(real)})
        return out
