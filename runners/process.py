"""Process-wide settings shared by the runners."""

from __future__ import annotations

import ctypes
import ctypes.util
import logging

log = logging.getLogger(__name__)

_M_TRIM_THRESHOLD = -1
_M_MMAP_THRESHOLD = -3


def keep_freed_memory(limit_bytes: int = 1 << 34) -> bool:
    """Ask glibc to keep freed memory instead of returning it to the OS.

    A particle rollout allocates and frees tens of MB per optimisation step; by default
    glibc serves large blocks with fresh ``mmap`` pages and trims the heap after each
    step, so every step pays page faults again (measured here: ~2x slower steps and
    large run-to-run variance). Call this before torch allocates anything. Returns
    False (and changes nothing) where the C library is not glibc.
    """
    name = ctypes.util.find_library("c")
    if name is None:
        return False
    try:
        libc = ctypes.CDLL(name)
        mallopt = libc.mallopt
    except (OSError, AttributeError):
        return False
    ok = bool(mallopt(_M_MMAP_THRESHOLD, min(limit_bytes, (1 << 31) - 1)))
    ok = ok and bool(mallopt(_M_TRIM_THRESHOLD, min(limit_bytes, (1 << 31) - 1)))
    log.debug("glibc mallopt keep-freed-memory: %s", ok)
    return ok
