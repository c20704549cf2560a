"""Configuration files parsed once, at the edge, into typed frozen objects.

* :func:`load_rig` — a rig file (TOML, format in ``rigs/README.md``) → :class:`~rigsim.scene.types.Rig`.
* :class:`~rigsim.config.reader.Section` — field-path-aware TOML table reader (one-line errors).
"""

from rigsim.config.reader import Section, read_toml
from rigsim.config.rig import load_rig, parse_rig

__all__ = ["Section", "read_toml", "load_rig", "parse_rig"]
