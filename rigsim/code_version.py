"""Which code computed a result: a hash of the package's source and of the data tables it reads.

A study's finished cases (``result.json``) and Monte Carlo checks (``check.json``) record it, so
that a study resumed after rigsim changed computes the results of other code again instead of
mixing two engines' numbers in one table (:mod:`rigsim.study.runner`; a case's id hashes its
inputs, not the code that computes it).  The hash is of the files themselves, not of a git commit:
it holds in an installed copy without git and changes with any edit.

A dataset's samples (``record.json``) record it the same way (:mod:`rigsim.dataset.writer`).

What it covers: every ``.py`` file of the package except those that only present results or take
commands (:data:`NOT_COMPUTING`: the web UI, the HTML report, the command line - none of the computing
packages imports them), and every table under
:data:`rigsim.data.DATA_DIR` except the fast engine's published agreement table (the benchmark's
output, read by the rig designer only).

Examples
--------
>>> v = code_version()
>>> len(v), v == code_version()
(12, True)
"""

from __future__ import annotations

import hashlib
from pathlib import Path

__all__ = ["code_version", "computed_here", "NOT_COMPUTING"]

#: Sub-packages of ``rigsim`` left out of the hash: they present results or take commands, not compute.
NOT_COMPUTING = ("ui", "report", "cli")
#: Folders of the data tree left out (relative to ``DATA_DIR``): outputs, not inputs.
_DATA_OUTPUTS = ("fast_engine",)


def _files() -> list[tuple[str, Path]]:
    from rigsim.data import DATA_DIR

    pkg = Path(__file__).resolve().parent
    files = [(f"rigsim/{p.relative_to(pkg).as_posix()}", p) for p in pkg.rglob("*.py")
             if p.relative_to(pkg).parts[0] not in NOT_COMPUTING]
    if DATA_DIR.is_dir():
        files += [(f"data/{p.relative_to(DATA_DIR).as_posix()}", p) for p in DATA_DIR.rglob("*")
                  if p.is_file() and p.relative_to(DATA_DIR).parts[0] not in _DATA_OUTPUTS]
    return sorted(files)


def _hash() -> str:
    h = hashlib.sha1()
    for name, path in _files():
        h.update(name.encode() + b"\0")
        h.update(path.read_bytes())
        h.update(b"\0")
    return h.hexdigest()[:12]


#: This process's code version, taken when this module is first imported - with the package, before any
#: work: files edited while a run goes on do not change what its processes say they loaded.
_LOADED = _hash()


def code_version() -> str:
    """12 hex digits of the SHA-1 over the computing code's and the data tables' names and contents, as they
    were when this process imported rigsim."""
    return _LOADED


def computed_here(record: dict) -> bool:
    """Whether a finished item's record names this code as the one that computed it (its ``code``, or
    ``meta.code`` for a study case); a record from before the field existed does not."""
    meta = record.get("meta")
    code = record.get("code", meta.get("code") if isinstance(meta, dict) else None)
    return code == code_version()
