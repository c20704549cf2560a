"""The one way rigsim reads configuration: TOML → pydantic models → one-line :class:`ConfigError`.

A foundation module (beside :mod:`rigsim.errors`): the file readers of :mod:`rigsim.config`
(and the sensor, study and dataset readers) and the self-validating scene types
(:mod:`rigsim.scene.types`) all build on it, and it imports neither.

Every kind of file (rig, water, sensor, study, dataset) is read by :func:`read_toml`
and validated by a :class:`FileModel` subclass (``extra="forbid"``: a typo is an
error); the frozen scene types (:mod:`rigsim.scene.types`) are pydantic dataclasses
made with :func:`frozen_type`, so they validate themselves when built from Python
too.  Whatever fails, :func:`config_error` turns pydantic's
:class:`~pydantic.ValidationError` into one line naming the file, the field path and
what is allowed::

    rigs/my-rig.toml: lights[1].beam_angle_deg: out of range: 400 (allowed: > 0 and < 360 (deg, full angle at half intensity))
    rigs/my-rig.toml: camera.focal_lenght_mm: unknown key 'focal_lenght_mm'; did you mean 'focal_length_mm'? (allowed: ...)
    Light.aim: must not be the zero vector (allowed: [x, y, z], three finite numbers, not all zero)

Building blocks
---------------
* Number types that refuse booleans and strings and NaN/inf, with ranges as
  ``Annotated[Real, Field(gt=0, lt=360), Unit("deg")]``: :data:`Real`, :data:`Int`,
  :data:`Vec3`, :data:`Direction`, :func:`float_table`.
* :func:`invalid` — the error a validator raises (message, optional sub-field, allowed).
* :func:`exclusive` — "give only one of" groups of keys.
* :func:`validate` / :func:`load_file` — validate a table / read and validate a file.
* :func:`reported_at` — re-home an error from a downstream package (a spectrum name,
  a CSV) at the file field it came from.

The allowed range in a message is read from the field's own constraints, so it
cannot disagree with what is checked.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import numbers
import os
import re
import tomllib
import types
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Annotated, Any, Literal, TypeVar, Union, get_args, get_origin

import annotated_types as at
import numpy as np
from pydantic import BaseModel, BeforeValidator, ConfigDict, Field, StrictBool, ValidationError
from pydantic.dataclasses import dataclass as pydantic_dataclass
from pydantic.fields import FieldInfo
from pydantic_core import PydanticCustomError

from rigsim.errors import ConfigError, unknown_name_error

__all__ = ["FileModel", "Unit", "Real", "Int", "Bool", "Vec3", "Direction", "float_table", "WavelengthGrid",
           "names_list", "frozen_type",
           "invalid", "exclusive", "built", "read_toml", "toml_from_text", "validate", "load_file", "config_error",
           "reported_at", "rehome", "allowed_for"]

M = TypeVar("M")


@dataclasses.dataclass(frozen=True)
class Unit:
    """Marker in a field's ``Annotated`` metadata: the unit (and a hint) shown in messages.

    Examples
    --------
    >>> Angle = Annotated[Real, Field(gt=0, lt=360), Unit("deg")]
    """

    text: str


# ---------------------------------------------------------------------------- errors raised by validators

def invalid(message: str, *, field: str | None = None, allowed: str | None = None) -> PydanticCustomError:
    """The error a validator raises: becomes ``file: path[.field]: message (allowed: ...)``.

    Parameters
    ----------
    message
        What is wrong, e.g. ``"must not be the zero vector"``.
    field
        Sub-path below the value being validated (``"up"`` in a model validator of
        ``camera``, ``"[0]"`` for the first item of a list), or None.
    allowed
        What would be accepted.
    """
    return PydanticCustomError("rigsim", "{message}", {"message": message, "field": field, "allowed": allowed})


def _fmt_num(x: Any) -> str:
    """A number as a user wrote it: ``-1``, ``0.25``, ``1e+06``."""
    if isinstance(x, bool) or not isinstance(x, numbers.Real):
        return repr(x)
    x = float(x)
    if math.isfinite(x) and x == int(x) and abs(x) < 1e7:
        return str(int(x))
    return f"{x:g}"


def _short(v: Any, n: int = 60) -> str:
    s = repr(v)
    return s if len(s) <= n else s[: n - 3] + "..."


# ---------------------------------------------------------------------------- value types

def _real(v: Any) -> float:
    if isinstance(v, (bool, np.bool_)) or not isinstance(v, numbers.Real):
        raise PydanticCustomError("number_type", "must be a number, got {got}", {"got": _short(v)})
    return float(v)


def _int(v: Any) -> int:
    if isinstance(v, (bool, np.bool_)) or not isinstance(v, numbers.Real):
        raise PydanticCustomError("number_type", "must be a number, got {got}", {"got": _short(v)})
    if isinstance(v, numbers.Integral):
        return int(v)
    x = float(v)
    if not math.isfinite(x):
        raise PydanticCustomError("finite_number", "must be finite, got {got}", {"got": repr(x)})
    if x != int(x):
        raise PydanticCustomError("int_from_float", "must be a whole number, got {got}", {"got": f"{x:g}"})
    return int(x)


#: A finite real number (int or float; not a bool, not a string; NaN and inf refused).
Real = Annotated[float, BeforeValidator(_real), Field(allow_inf_nan=False)]
#: A whole number (an int, or a float with no fractional part; not a bool).
Int = Annotated[int, BeforeValidator(_int)]
#: true or false (not 0/1, not "yes").
Bool = StrictBool


def _vec3(nonzero: bool) -> Callable[[Any], tuple[float, float, float]]:
    allowed = "[x, y, z], three finite numbers" + (", not all zero" if nonzero else "")

    def check(v: Any) -> tuple[float, float, float]:
        if isinstance(v, np.ndarray):
            v = v.tolist()
        if isinstance(v, (str, bytes)) or not isinstance(v, Sequence) or len(v) != 3 or any(
                isinstance(x, (bool, np.bool_)) or not isinstance(x, numbers.Real) for x in v):
            raise invalid(f"must be a list of 3 numbers, got {_short(v)}", allowed=allowed)
        t = tuple(float(x) for x in v)
        if not all(math.isfinite(x) for x in t):
            raise invalid(f"must be finite, got {_short(list(v))}", allowed=allowed)
        if nonzero and all(x == 0 for x in t):
            raise invalid("must not be the zero vector", allowed=allowed)
        return t  # type: ignore[return-value]

    return check


#: Three finite numbers ``(x, y, z)`` (a list, tuple or array).
Vec3 = Annotated[tuple[float, float, float], BeforeValidator(_vec3(False))]
#: A direction: three finite numbers, not all zero (not normalised).
Direction = Annotated[tuple[float, float, float], BeforeValidator(_vec3(True))]


def float_table(*, increasing: bool = False, nonnegative: bool = False, min_length: int = 0,
                unit: str = "") -> Any:
    """The type of a table column: a tuple of finite floats (from a list, tuple or array).

    Parameters
    ----------
    increasing
        Values must increase strictly (wavelength grids, angles).
    nonnegative
        Values must be >= 0 (intensities, reflectances).
    min_length
        Fewest entries.
    unit
        Unit for messages.
    """
    parts = ["finite numbers"]
    if increasing:
        parts.append("strictly increasing")
    if nonnegative:
        parts.append(">= 0")
    if min_length:
        parts.append(f"at least {min_length}")
    allowed = ", ".join(parts) + (f" ({unit})" if unit else "")

    def check(v: Any) -> tuple[float, ...]:
        if isinstance(v, np.ndarray):
            if v.ndim != 1:
                raise invalid(f"must be a 1-D list of numbers, got an array of shape {v.shape}", allowed=allowed)
            v = v.tolist()
        if isinstance(v, (str, bytes)) or not isinstance(v, Sequence) or any(
                isinstance(x, (bool, np.bool_)) or not isinstance(x, numbers.Real) for x in v):
            raise invalid(f"must be a list of numbers, got {_short(v)}", allowed=allowed)
        a = np.asarray(v, float)
        if a.size < min_length:
            raise invalid(f"needs at least {min_length} values, got {a.size}", allowed=allowed)
        if not np.all(np.isfinite(a)):
            raise invalid("values must be finite (no NaN or inf)", allowed=allowed)
        if nonnegative and np.any(a < 0):
            raise invalid(f"values must be >= 0, got {_fmt_num(a.min())}", allowed=allowed)
        if increasing and np.any(np.diff(a) <= 0):
            raise invalid("values must increase strictly", allowed=allowed)
        return tuple(a.tolist())

    return Annotated[tuple[float, ...], BeforeValidator(check)]


def _wavelength_grid(v: Any) -> tuple[float, ...]:
    allowed = "START:STOP:STEP in nm (e.g. 400:700:10), a comma list, or a list of numbers"
    if not isinstance(v, (str, list, tuple, np.ndarray)) or (not isinstance(v, str) and any(
            isinstance(x, (bool, np.bool_)) or not isinstance(x, numbers.Real) for x in v)):
        raise invalid(f"cannot read wavelengths {_short(v)}", allowed=allowed)
    from rigsim.spectrum import as_wavelength_grid  # the one parser of wavelength lists

    try:
        wl = as_wavelength_grid(v)
    except ConfigError as exc:
        raise invalid(exc.message, allowed=exc.allowed or allowed) from None
    if wl.ndim != 1 or wl.size == 0:
        raise invalid(f"cannot read wavelengths {_short(v)}", allowed=allowed)
    return tuple(float(x) for x in wl)


#: Wavelengths (nm): ``"400:700:10"`` (stop included), ``"450,550"`` or a list of numbers.
WavelengthGrid = Annotated[tuple[float, ...], BeforeValidator(_wavelength_grid)]


def names_list(*, allow_empty: bool = False) -> Any:
    """The type of a list of names (file names, presets); a single string counts as a list of one."""
    what = "a list of names" if allow_empty else "a non-empty list of names"

    def check(v: Any) -> tuple[str, ...]:
        if isinstance(v, str):
            v = [v]
        if not isinstance(v, (list, tuple)) or (not v and not allow_empty) or not all(isinstance(x, str) for x in v):
            raise invalid(f"must be {what}, got {_short(v)}", allowed=what)
        return tuple(v)

    return Annotated[tuple[str, ...], BeforeValidator(check)]


# ---------------------------------------------------------------------------- models

class FileModel(BaseModel):
    """Base of every file schema: unknown keys are errors, instances are frozen.

    Subclasses may set ``KEY_ALIASES`` (alias → canonical key) so that unknown-key
    messages list the aliases too.
    """

    model_config = ConfigDict(extra="forbid", frozen=True)


#: Configuration of the frozen scene types (pydantic dataclasses).
TYPE_CONFIG = ConfigDict(extra="forbid")


def frozen_type(cls: type[M] | None = None, *, eq: bool = True, arbitrary_types: bool = False) -> Any:
    """Make ``cls`` a frozen pydantic dataclass that raises :class:`ConfigError` when invalid.

    The class keeps the standard-library dataclass behaviour (``dataclasses.replace``,
    ``asdict``, ``fields``, hashing when ``eq``); building it with a bad value raises
    ``ConfigError("ClassName.field: ... (allowed: ...)")`` instead of
    :class:`pydantic.ValidationError`.

    Parameters
    ----------
    eq
        Generate ``__eq__`` (and ``__hash__``).
    arbitrary_types
        Allow fields of types pydantic does not know (checked by ``isinstance``).
    """

    def wrap(c: type[M]) -> type[M]:
        config = ConfigDict(TYPE_CONFIG, arbitrary_types_allowed=arbitrary_types)
        pc = pydantic_dataclass(c, frozen=True, eq=eq, config=config)
        init = pc.__init__

        @functools.wraps(init)
        def __init__(self, *args: Any, **kwargs: Any) -> None:
            try:
                init(self, *args, **kwargs)
            except ValidationError as exc:
                raise config_error(exc, pc, prefix=pc.__name__) from None

        pc.__init__ = __init__  # type: ignore[method-assign]
        return pc

    return wrap if cls is None else wrap(cls)


def exclusive(model: Any, *groups: Sequence[str], required: bool = False) -> int | None:
    """Which of several mutually exclusive groups of keys a table uses (index), or None.

    A group is used if any of its keys is set (not None).  Raises :func:`invalid` for
    two groups at once (at the second key) or, if ``required``, for none (at the
    first key of the first group).
    """
    used = [i for i, g in enumerate(groups) if any(getattr(model, k) is not None for k in g)]
    names = " | ".join("/".join(g) for g in groups)
    if len(used) > 1:
        a = next(k for k in groups[used[0]] if getattr(model, k) is not None)
        b = next(k for k in groups[used[1]] if getattr(model, k) is not None)
        raise invalid(f"give only one of {a!r} and {b!r}", field=b, allowed=f"one of {names}")
    if not used:
        if required:
            raise invalid("missing required field", field=groups[0][0], allowed=f"one of {names}")
        return None
    return used[0]


def built(cls: Callable[..., M], /, *args: Any, **kwargs: Any) -> M:
    """Build a frozen type inside a file model's validator.

    A :class:`ConfigError` of the type (``"Camera.up: ..."``) is raised again as
    :func:`invalid` at the same-named field of the table being validated, so the
    checks written on the type serve the file too.
    """
    try:
        return cls(*args, **kwargs)
    except ConfigError as exc:
        sub = exc.field.split(".", 1)[1] if exc.field and "." in exc.field else None
        raise invalid(exc.message, field=sub, allowed=exc.allowed) from None


def allowed_for(model: type, name: str) -> str | None:
    """The allowed-values text of field ``name`` of ``model`` (from its constraints)."""
    info = _fields_of(model)[name]
    tp, meta = _unwrap(info.annotation, list(info.metadata))
    return _allowed(tp, meta)


# ---------------------------------------------------------------------------- reading TOML

_TOML_POS = re.compile(r"^(.*) \(at line (\d+), column (\d+)\)$")


def toml_from_text(text: str, *, source: str | Path = "<text>") -> dict[str, Any]:
    """Parse TOML text; a syntax error becomes a one-line :class:`ConfigError` naming ``source``.

    Examples
    --------
    >>> toml_from_text("a = 1")
    {'a': 1}
    >>> toml_from_text("a 1", source="x.toml")
    Traceback (most recent call last):
    ...
    rigsim.errors.ConfigError: x.toml: malformed TOML: not valid TOML at line 1, column 3: Expected '=' after a key in a key/value pair
    """
    if "\x00" in text:
        raise ConfigError("binary file, not TOML text (contains NUL bytes)", file=source,
                          allowed="a UTF-8 TOML text file")
    try:
        return tomllib.loads(text)
    except RecursionError:
        raise ConfigError("malformed TOML: arrays or tables nested too deeply", file=source,
                          allowed="a TOML file nested a few levels deep") from None
    except tomllib.TOMLDecodeError as exc:
        detail = " ".join(str(exc).split())
        m = _TOML_POS.match(detail)
        where = f" at line {m.group(2)}, column {m.group(3)}" if m else ""
        what = m.group(1) if m else detail
        raise ConfigError(f"malformed TOML: not valid TOML{where}: {what}", file=source) from None


def read_toml(path: str | Path) -> dict[str, Any]:
    """Read a TOML file into plain Python values (the only place rigsim parses TOML).

    Raises
    ------
    ConfigError
        One line naming the file: not found, not a file, unreadable, binary or not
        UTF-8, or malformed TOML (with line and column).
    """
    p = Path(path)
    if not os.path.exists(p):
        raise ConfigError("file not found", file=p, allowed="an existing TOML file")
    if not os.path.isfile(p):
        raise ConfigError("not a file", file=p, allowed="a TOML file")
    try:
        raw = p.read_bytes()
    except OSError as exc:
        raise ConfigError(f"cannot read: {exc.strerror or exc}", file=p) from None
    if b"\x00" in raw:
        raise ConfigError("binary file, not TOML text (contains NUL bytes)", file=p, allowed="a UTF-8 TOML text file")
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ConfigError(f"not UTF-8 text (byte 0x{raw[exc.start]:02x} at offset {exc.start})", file=p,
                          allowed="a UTF-8 TOML text file") from None
    return toml_from_text(text, source=p)


def validate(schema: type[M], data: Any, *, file: str | Path | None = None, prefix: str = "",
             context: dict | None = None) -> M:
    """Validate ``data`` (a parsed table) against a :class:`FileModel` subclass.

    Parameters
    ----------
    schema
        The model.
    data
        The table (e.g. from :func:`read_toml`).
    file
        The file, for messages.
    prefix
        Field path of ``data`` in the file (``"water"`` for the ``[water]`` table).
    context
        Passed to the validators (``info.context``).
    """
    try:
        return schema.model_validate(data, context=context)  # type: ignore[attr-defined]
    except ValidationError as exc:
        raise config_error(exc, schema, file=file, prefix=prefix) from None
    except RecursionError:
        raise ConfigError("values nested too deeply", file=file, field=prefix or None) from None


def load_file(schema: type[M], path: str | Path, *, context: dict | None = None) -> M:
    """:func:`read_toml` then :func:`validate`: a whole file as a model."""
    return validate(schema, read_toml(path), file=path, context=context)


def rehome(exc: ConfigError, *, file: str | Path | None, field: str) -> ConfigError:
    """An error raised below the config layer (a spectrum, a CSV, a preset) re-homed at a file field.

    An error that names another file (a CSV) keeps that file and its field in the message.
    """
    if exc.file is not None and file is not None and exc.file == str(file) and exc.field:
        return exc  # already placed in this file
    where = f"{exc.file}: " if exc.file is not None else ""
    inner = f"{exc.field}: " if exc.file is not None and exc.field else ""
    return ConfigError(f"{where}{inner}{exc.message}", file=file, field=field, allowed=exc.allowed)


@contextmanager
def reported_at(file: str | Path | None, field: str) -> Iterator[None]:
    """``with reported_at(file, "lights[0].spectrum"): ...`` — a ConfigError inside is :func:`rehome`-d."""
    try:
        yield
    except ConfigError as exc:
        raise rehome(exc, file=file, field=field) from None


# ---------------------------------------------------------------------------- ValidationError → ConfigError

def _fields_of(tp: Any) -> dict[str, FieldInfo] | None:
    if isinstance(tp, type):
        if issubclass(tp, BaseModel):
            return tp.model_fields
        f = getattr(tp, "__pydantic_fields__", None)
        if f is not None:
            return f
    return None


def _unwrap(tp: Any, meta: list) -> tuple[Any, list]:
    """Strip ``Annotated`` and ``X | None``; collect the metadata (constraints, units)."""
    while True:
        origin = get_origin(tp)
        if origin is Annotated:
            args = get_args(tp)
            tp = args[0]
            for m in args[1:]:
                meta.extend(m.metadata if isinstance(m, FieldInfo) else [m])
        elif origin in (Union, types.UnionType):
            args = [a for a in get_args(tp) if a is not type(None)]
            if len(args) != 1:
                return tp, meta
            tp = args[0]
        else:
            return tp, meta


def _walk(schema: Any, loc: tuple) -> tuple[list, Any, list, Any]:
    """Follow an error location through the schema.

    Returns the path (field names and indices), the type and metadata at its end,
    and the type holding the last key (for unknown-key suggestions).
    """
    path: list = []
    tp, meta, parent = schema, [], None
    for part in loc:
        parent = tp
        fields = _fields_of(tp)
        if fields is not None:
            names = list(fields)
            name = names[part] if isinstance(part, int) and 0 <= part < len(names) else part
            path.append(name)
            if name in fields:
                info = fields[name]
                tp, meta = _unwrap(info.annotation, list(info.metadata))
            else:
                tp, meta = None, []
            continue
        path.append(part)
        origin, args = get_origin(tp), get_args(tp)
        if isinstance(part, int) and origin in (list, tuple, set, frozenset) and args:
            if origin is tuple and args[-1] is not Ellipsis:
                el = args[part] if part < len(args) else None
            else:
                el = args[0]
            tp, meta = _unwrap(el, [])
        elif origin is dict and len(args) == 2:
            tp, meta = _unwrap(args[1], [])
        else:
            tp, meta = None, []
    return path, tp, meta, parent


def _join(path: Sequence, prefix: str = "") -> str:
    out = prefix
    for p in path:
        if isinstance(p, int):
            out += f"[{p}]"
        else:
            out += f".{p}" if out else str(p)
    return out


def _parse_path(text: str) -> list:
    """``"lights[0].aim"`` → ``["lights", 0, "aim"]``."""
    return [int(i) if i else k for k, i in re.findall(r"([^.\[\]]+)|\[(\d+)\]", text)]


def _range(meta: list) -> str | None:
    lo = hi = None
    for m in meta:
        if isinstance(m, at.Gt):
            lo = f"> {_fmt_num(m.gt)}"
        elif isinstance(m, at.Ge):
            lo = f">= {_fmt_num(m.ge)}"
        elif isinstance(m, at.Lt):
            hi = f"< {_fmt_num(m.lt)}"
        elif isinstance(m, at.Le):
            hi = f"<= {_fmt_num(m.le)}"
    return " and ".join(x for x in (lo, hi) if x) or None


def _allowed(tp: Any, meta: list) -> str | None:
    unit = next((m.text for m in meta if isinstance(m, Unit)), None)
    if get_origin(tp) is Literal:
        text = ", ".join(str(a) for a in sorted(get_args(tp), key=str))
    else:
        text = _range(meta)
    if text and unit:
        return f"{text} ({unit})"
    return text or (f"a number ({unit})" if unit else None)


def _what(tp: Any) -> str:
    if _fields_of(tp) is not None:
        return "a table" if isinstance(tp, type) and issubclass(tp, BaseModel) else f"a {tp.__name__}"
    return "a value of the right kind"


def config_error(exc: ValidationError, schema: Any, *, file: str | Path | None = None,
                 prefix: str = "") -> ConfigError:
    """The first error of a :class:`~pydantic.ValidationError` as one-line :class:`ConfigError`.

    Unknown keys are reported before other errors (a misspelt key also leaves the
    real one missing); otherwise the first error in field order.

    Parameters
    ----------
    exc
        From validating ``schema``.
    schema
        The model or pydantic dataclass that was validated (to find each field's
        constraints, units, choices and known keys).
    file
        The file, for the message.
    prefix
        Path of the validated value (``"water"``, or a class name for Python-built types).
    """
    errors = exc.errors(include_url=False)
    # an unknown key first: a misspelt key also makes the real one look missing
    err = next((e for e in errors if e["type"] in ("extra_forbidden", "unexpected_keyword_argument")), errors[0])
    kind, ctx, value = err["type"], err.get("ctx") or {}, err.get("input")
    path, tp, meta, parent = _walk(schema, tuple(err["loc"]))
    sub = ctx.get("field") if kind == "rigsim" else None
    if sub:
        parts = _parse_path(sub)
        _, tp, meta, _ = _walk(tp, tuple(parts))
        path = path + parts
    field = _join(path, prefix)
    field_or_none = field or None
    allowed = _allowed(tp, meta)

    if kind in ("extra_forbidden", "unexpected_keyword_argument"):
        key = str(path[-1]) if path else "?"
        known = list(_fields_of(parent) or ())
        known += list(getattr(parent, "KEY_ALIASES", {}) or {})
        return unknown_name_error("key" if kind == "extra_forbidden" else "argument", key, known, file=file,
                                  field=field_or_none)
    if kind == "literal_error":
        choices = [str(a) for a in get_args(tp)] if get_origin(tp) is Literal else []
        label = str(path[-1]).replace("_", " ") if path else "value"
        if isinstance(value, str) and choices:
            return unknown_name_error(label, value, choices, file=file, field=field_or_none)
        message = f"must be one of {', '.join(choices)}, got {_short(value)}" if choices else err["msg"]
    elif kind == "rigsim":
        message, allowed = ctx["message"], ctx.get("allowed") or allowed
    elif kind == "value_error" and isinstance(ctx.get("error"), ConfigError):
        inner = ctx["error"]
        message, allowed = inner.message, inner.allowed or allowed
    elif kind in ("missing", "missing_argument", "missing_positional_argument", "missing_keyword_only_argument"):
        message = "missing required field"
    elif kind == "finite_number":
        message = f"must be finite, got {value}"
    elif kind in ("greater_than", "greater_than_equal", "less_than", "less_than_equal"):
        message = f"out of range: {_fmt_num(value)}"
    elif kind in ("number_type", "int_from_float") or kind.startswith(("float_", "int_")):
        message = err["msg"] if kind in ("number_type", "int_from_float") else f"must be a number, got {_short(value)}"
    elif kind == "string_type":
        message = f"must be a string, got {_short(value)}"
    elif kind == "bool_type":
        message, allowed = f"must be true or false, got {_short(value)}", "true, false"
    elif kind in ("model_type", "model_attributes_type", "dict_type", "dataclass_type", "dataclass_exact_type"):
        message = f"must be {_what(tp)}, got {_short(value)}"
        if _fields_of(tp) is not None and isinstance(tp, type) and issubclass(tp, BaseModel):
            allowed = "a TOML table with keys " + ", ".join(_fields_of(tp) or ())
    elif kind == "is_instance_of":
        message = f"must be a {ctx.get('class', 'value of the right type')}, got {type(value).__name__}"
    elif kind in ("tuple_type", "list_type"):
        message = f"must be a list, got {_short(value)}"
    elif kind == "too_short":
        message = f"needs at least {ctx.get('min_length')} entries, got {ctx.get('actual_length')}"
    elif kind == "too_long":
        message = f"takes at most {ctx.get('max_length')} entries, got {ctx.get('actual_length')}"
    elif kind == "unexpected_positional_argument":
        n = len(_fields_of(schema) or ())
        message, field_or_none, allowed = "too many positional arguments", prefix or None, f"at most {n}"
    else:
        message = re.sub(r"^(Value|Assertion) error, ", "", err["msg"])
    message = " ".join(str(message).split())
    return ConfigError(message, file=file, field=field_or_none,
                       allowed=" ".join(allowed.split()) if allowed else None)

