"""Configuration files parsed once, at the edge, into typed frozen objects — one mechanism.

* :mod:`rigsim.config.schema` — the mechanism: :func:`~rigsim.config.schema.read_toml`,
  the :class:`~rigsim.config.schema.FileModel` base (pydantic, unknown keys are
  errors), the value types and :func:`~rigsim.config.schema.config_error` (one-line
  errors naming file, field path and allowed range).
* :func:`load_rig` — a rig file (TOML, format in ``rigs/README.md``) → :class:`~rigsim.scene.types.Rig`.
* :mod:`rigsim.config.water` — water files and presets; sensors, studies and datasets
  are read by :mod:`rigsim.sensor.model`, :mod:`rigsim.study.spec` and
  :mod:`rigsim.dataset.spec` with the same mechanism.

``load_rig`` and ``parse_rig`` are imported lazily: the scene types use
:mod:`rigsim.config.schema` themselves, and the rig reader needs the scene types.
"""

from rigsim.config.schema import FileModel, config_error, load_file, read_toml, validate

__all__ = ["FileModel", "config_error", "load_file", "read_toml", "validate", "load_rig", "parse_rig"]


def __getattr__(name: str):
    if name in ("load_rig", "parse_rig"):
        from rigsim.config import rig

        return getattr(rig, name)
    raise AttributeError(f"module 'rigsim.config' has no attribute {name!r}")
