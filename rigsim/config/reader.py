"""Reading TOML tables field by field, with one-line errors naming file, field path and allowed values.

:class:`Section` wraps one TOML table (``camera``, ``lights[1]`` …).  It rejects
unknown keys on construction (suggesting the nearest known key), and each
getter checks type and range and raises :class:`~rigsim.errors.ConfigError`
whose message reads ``file: lights[1].beam_angle_deg: must be > 0 and < 360,
got 400 (allowed: 0 < beam_angle_deg < 360 (deg))``.
"""

from __future__ import annotations

import math
import tomllib
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

from rigsim.errors import ConfigError, unknown_name_error

__all__ = ["Section", "read_toml", "MISSING"]


class _Missing:
    def __repr__(self) -> str:
        return "MISSING"


#: Sentinel: a required field.
MISSING: Any = _Missing()


def read_toml(path: str | Path) -> dict:
    """Parse a TOML file; a missing file or a syntax error becomes a one-line ConfigError."""
    p = Path(path)
    if not p.exists():
        raise ConfigError("file not found", file=p, allowed="an existing TOML file")
    if not p.is_file():
        raise ConfigError("not a file", file=p, allowed="a TOML file")
    try:
        with p.open("rb") as fh:
            return tomllib.load(fh)
    except tomllib.TOMLDecodeError as exc:
        # tomllib messages end with "(at line L, column C)"
        raise ConfigError(f"malformed TOML: {exc}", file=p) from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(f"cannot read: {getattr(exc, 'strerror', None) or exc}", file=p) from None


def _fmt(x: float) -> str:
    return f"{x:g}"


class Section:
    """One TOML table at a field path, with typed, range-checked getters.

    Parameters
    ----------
    data
        The table (must be a dict, else ConfigError).
    path
        Field path of the table, e.g. ``"lights[1]"`` (``""`` for the top level).
    file
        The file, for messages.
    known
        The keys this table may hold; any other key is an error.
    """

    def __init__(self, data: Any, path: str, file: str | Path | None, known: Iterable[str]):
        self.path = path
        self.file = file
        self.known = tuple(known)
        if not isinstance(data, dict):
            raise ConfigError(f"must be a table, got {type(data).__name__}", file=file,
                              field=path or None, allowed="a TOML table [..] with keys")
        self.data = data
        for key in data:
            if key not in self.known:
                raise unknown_name_error("key", key, self.known, file=file, field=self.field(key))

    def field(self, key: str) -> str:
        """Dotted path of ``key`` in this table."""
        return f"{self.path}.{key}" if self.path else key

    def error(self, key: str, message: str, allowed: str | None = None) -> ConfigError:
        """A ConfigError for ``key`` of this table."""
        return ConfigError(message, file=self.file, field=self.field(key), allowed=allowed)

    def has(self, key: str) -> bool:
        return key in self.data

    def _get(self, key: str, default: Any, what: str) -> Any:
        if key not in self.data:
            if default is MISSING:
                raise self.error(key, "missing required field", what)
            return default
        return self.data[key]

    def number(self, key: str, default: Any = MISSING, *, gt: float | None = None,
               ge: float | None = None, lt: float | None = None, le: float | None = None,
               unit: str = "") -> Any:
        """A finite real number in the given range (bools are not numbers)."""
        parts = []
        if gt is not None:
            parts.append(f"> {_fmt(gt)}")
        if ge is not None:
            parts.append(f">= {_fmt(ge)}")
        if lt is not None:
            parts.append(f"< {_fmt(lt)}")
        if le is not None:
            parts.append(f"<= {_fmt(le)}")
        rng = " and ".join(parts) if parts else "any number"
        allowed = f"{key} {rng}" + (f" ({unit})" if unit else "")
        v = self._get(key, default, allowed)
        if v is default and key not in self.data:
            return v
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise self.error(key, f"must be a number, got {v!r}", allowed)
        v = float(v)
        if not math.isfinite(v):
            raise self.error(key, f"must be finite, got {v}", allowed)
        if (gt is not None and not v > gt) or (ge is not None and not v >= ge) or \
                (lt is not None and not v < lt) or (le is not None and not v <= le):
            raise self.error(key, f"must be {rng}, got {_fmt(v)}", allowed)
        return v

    def string(self, key: str, default: Any = MISSING, *, choices: Sequence[str] | None = None) -> Any:
        """A string, optionally one of ``choices``."""
        allowed = ", ".join(repr(c) for c in choices) if choices else "a string"
        v = self._get(key, default, allowed)
        if v is default and key not in self.data:
            return v
        if not isinstance(v, str):
            raise self.error(key, f"must be a string, got {v!r}", allowed)
        if choices is not None and v not in choices:
            raise unknown_name_error(key.replace("_", " "), v, choices, file=self.file, field=self.field(key))
        return v

    def vector(self, key: str, default: Any = MISSING, *, nonzero: bool = False) -> Any:
        """A 3-vector of finite numbers ``[x, y, z]``."""
        allowed = "[x, y, z], three numbers" + (", not all zero" if nonzero else "")
        v = self._get(key, default, allowed)
        if v is default and key not in self.data:
            return v
        if not isinstance(v, list) or len(v) != 3 or any(
                isinstance(x, bool) or not isinstance(x, (int, float)) for x in v):
            raise self.error(key, f"must be a list of 3 numbers, got {v!r}", allowed)
        t = tuple(float(x) for x in v)
        if not all(math.isfinite(x) for x in t):
            raise self.error(key, f"must be finite, got {v!r}", allowed)
        if nonzero and all(x == 0 for x in t):
            raise self.error(key, "must not be the zero vector", allowed)
        return t

    def exclusive(self, *groups: Sequence[str], required: bool = False) -> int | None:
        """Which of several mutually exclusive groups of keys is used (index), or None.

        A group counts as used if any of its keys is present; using two groups is an error.
        """
        used = [i for i, g in enumerate(groups) if any(k in self.data for k in g)]
        names = " | ".join("/".join(g) for g in groups)
        if len(used) > 1:
            a = next(k for k in groups[used[0]] if k in self.data)
            b = next(k for k in groups[used[1]] if k in self.data)
            raise self.error(b, f"give only one of {a!r} and {b!r}", f"one of {names}")
        if not used:
            if required:
                raise self.error(groups[0][0], "missing required field", f"one of {names}")
            return None
        return used[0]
