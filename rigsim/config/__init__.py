"""Configuration files parsed once, at the edge, into typed frozen objects — one mechanism.

* :mod:`rigsim.schema` — the mechanism: :func:`~rigsim.schema.read_toml`,
  the :class:`~rigsim.schema.FileModel` base (pydantic, unknown keys are
  errors), the value types and :func:`~rigsim.schema.config_error` (one-line
  errors naming file, field path and allowed range).
* :func:`load_rig` — a rig file (TOML, format in ``rigs/README.md``) → :class:`~rigsim.scene.types.Rig`.
* :mod:`rigsim.config.rigdoc` — a rig file as an editable document (the rig designer's edits and the
  optimiser's moves, written back as the same TOML).
* :mod:`rigsim.config.water` — water files and presets; sensors, studies and datasets
  are read by :mod:`rigsim.sensor.model`, :mod:`rigsim.study.spec` and
  :mod:`rigsim.dataset.spec` with the same mechanism.
"""

from rigsim.config.rig import load_rig, parse_rig
from rigsim.schema import FileModel, config_error, load_file, read_toml, validate

__all__ = ["FileModel", "config_error", "load_file", "read_toml", "validate", "load_rig", "parse_rig"]
