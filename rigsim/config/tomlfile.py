"""Reading TOML files with one-line errors (file, line, field)."""

from __future__ import annotations

import tomllib
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

from rigsim.errors import ConfigError, unknown_name_error


def read_toml(path: str | Path) -> dict[str, Any]:
    """Read a TOML file; a missing file or a syntax error becomes a :class:`ConfigError`."""
    p = Path(path)
    if not p.is_file():
        raise ConfigError("file not found" if not p.exists() else "not a file", file=p)
    try:
        with p.open("rb") as fh:
            return tomllib.load(fh)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"malformed TOML: {exc}", file=p) from None
    except OSError as exc:
        raise ConfigError(f"cannot read: {exc.strerror or exc}", file=p) from None


def check_keys(table: Mapping[str, Any], allowed: Iterable[str], *, file: str | Path | None,
               prefix: str = "") -> None:
    """Refuse keys that are not in ``allowed`` (a typo must fail loudly)."""
    allowed = list(allowed)
    for key in table:
        if key not in allowed:
            raise unknown_name_error("key", key, allowed, file=file, field=f"{prefix}{key}")


def get_number(table: Mapping[str, Any], key: str, *, file, prefix: str = "", default=None,
               minimum: float | None = None, maximum: float | None = None,
               exclusive_minimum: bool = False) -> float | None:
    """A number from a table, range-checked, or ``default`` if absent."""
    if key not in table:
        return default
    v = table[key]
    lo = "" if minimum is None else (f"> {minimum:g}" if exclusive_minimum else f">= {minimum:g}")
    hi = "" if maximum is None else f"<= {maximum:g}"
    allowed = " and ".join(x for x in (lo, hi) if x) or "a number"
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise ConfigError(f"must be a number, got {v!r}", file=file, field=f"{prefix}{key}", allowed=allowed)
    v = float(v)
    bad = (v != v) or (minimum is not None and (v <= minimum if exclusive_minimum else v < minimum)) or (
        maximum is not None and v > maximum)
    if bad:
        raise ConfigError(f"out of range: {v:g}", file=file, field=f"{prefix}{key}", allowed=allowed)
    return v
