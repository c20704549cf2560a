"""What the machine can give a run: memory (so that a too-large request is refused before
anything is allocated, with the amount it would need).

Examples
--------
>>> format_bytes(3 * 2**30)
'3.2 GB'
>>> available_memory_bytes() > 0
True
"""

from __future__ import annotations

import os
from pathlib import Path

__all__ = ["available_memory_bytes", "format_bytes", "check_memory"]


def _cgroup_limit() -> int | None:
    """The memory limit of this process's cgroup (v2 or v1), if any, minus what it uses."""
    for limit_f, used_f in (("/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory.current"),
                            ("/sys/fs/cgroup/memory/memory.limit_in_bytes",
                             "/sys/fs/cgroup/memory/memory.usage_in_bytes")):
        try:
            text = Path(limit_f).read_text().strip()
        except OSError:
            continue
        if not text.isdigit():  # "max": no limit
            return None
        limit = int(text)
        if limit >= 1 << 60:
            return None
        try:
            used = int(Path(used_f).read_text().strip())
        except (OSError, ValueError):
            used = 0
        return max(limit - used, 0)
    return None


def available_memory_bytes() -> int:
    """Memory a new allocation can use now: ``MemAvailable`` (Linux), capped by a cgroup limit.

    Falls back to the physical memory (``sysconf``) elsewhere, and to 8 GiB if nothing is known.
    """
    avail = None
    try:
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemAvailable:"):
                avail = int(line.split()[1]) * 1024
                break
    except (OSError, ValueError, IndexError):
        pass
    if avail is None:
        try:
            avail = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
        except (ValueError, OSError, AttributeError):
            avail = 8 << 30
    cg = _cgroup_limit()
    return min(avail, cg) if cg is not None else avail


def format_bytes(n: float) -> str:
    """``n`` bytes in SI units with 2 significant digits (``'3.2 GB'``, ``'19 TB'``)."""
    n = float(n)
    for unit in ("B", "kB", "MB", "GB", "TB", "PB", "EB"):
        if n < 999.5 or unit == "EB":
            return f"{n:.2g} {unit}" if n < 10 else f"{n:.0f} {unit}"
        n /= 1000.0
    return f"{n:.0f} EB"  # pragma: no cover


def check_memory(need_bytes: float, what: str, *, field: str | None = None, fraction: float = 0.8) -> None:
    """Refuse (one-line :class:`~rigsim.errors.ConfigError`) a request that needs more than
    ``fraction`` of the memory available now, saying how much it would need."""
    from rigsim.errors import ConfigError

    avail = available_memory_bytes()
    if need_bytes > fraction * avail:
        raise ConfigError(f"{what} would need about {format_bytes(need_bytes)} of memory; "
                          f"{format_bytes(avail)} is available", field=field,
                          allowed=f"a request that fits in memory (below about {format_bytes(fraction * avail)})")
