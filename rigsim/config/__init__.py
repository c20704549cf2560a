"""Parse and validate user files (rigs, waters, sensors, studies) once, at the edge.

Everything below :mod:`rigsim.config` receives typed objects, never dicts or paths.
Errors name the file, the field and the allowed values (:class:`rigsim.errors.ConfigError`).
"""
