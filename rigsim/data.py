"""Loading of the tabulated data in ``data/`` (each file carries its provenance header).

Tables are CSV files whose leading ``#`` lines name the source and units; the
first non-comment line holds the column names.  They are read once and cached.
"""

from __future__ import annotations

import csv
import functools
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rigsim.errors import DataError

#: Root of the data tree: ``$RIGSIM_DATA`` if set, else ``data/`` beside the package.
DATA_DIR = Path(os.environ.get("RIGSIM_DATA", Path(__file__).resolve().parent.parent / "data"))


@dataclass(frozen=True)
class Table:
    """A CSV table with its provenance header.

    Attributes
    ----------
    path
        File the table was read from.
    header
        The comment lines (without ``#``), i.e. source, units and notes.
    columns
        Column name → array; numeric columns are float arrays (blank cells are NaN),
        other columns are arrays of str.
    """

    path: Path
    header: tuple[str, ...]
    columns: dict[str, np.ndarray]

    def __getitem__(self, name: str) -> np.ndarray:
        try:
            return self.columns[name]
        except KeyError:
            raise DataError(f"{self.path}: no column {name!r} (has {', '.join(self.columns)})") from None

    @property
    def source(self) -> str:
        """The provenance header as one string."""
        return "\n".join(self.header)


def _to_array(values: list[str]) -> np.ndarray:
    try:
        return np.array([float(v) if v.strip() != "" else np.nan for v in values], dtype=float)
    except ValueError:
        return np.array(values, dtype=str)


def read_csv_table(path: str | Path) -> Table:
    """Read a CSV table with a ``#`` comment header (not cached; see :func:`load_table`)."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8").splitlines()
    except OSError as exc:
        raise DataError(f"cannot read data file {path}: {exc.strerror or exc}") from None
    header = tuple(line.lstrip("#").strip() for line in text if line.startswith("#"))
    rows = list(csv.reader(line for line in text if line.strip() and not line.startswith("#")))
    if not rows:
        raise DataError(f"{path}: no column header line")
    names = [n.strip() for n in rows[0]]
    body = rows[1:]
    for i, row in enumerate(body):
        if len(row) != len(names):
            raise DataError(f"{path}: data row {i + 1} has {len(row)} cells, expected {len(names)}")
    columns = {n: _to_array([r[j] for r in body]) for j, n in enumerate(names)}
    return Table(path=path, header=header, columns=columns)


@functools.lru_cache(maxsize=None)
def load_table(relative_path: str) -> Table:
    """Load (once) a table from the data tree, e.g. ``"water/jerlov_1976_kd.csv"``."""
    return read_csv_table(DATA_DIR / relative_path)
