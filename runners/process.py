"""Process-wide settings shared by the runners."""

from __future__ import annotations

import ctypes
import ctypes.util
import logging
from pathlib import Path

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


def also_log_to(path: Path) -> None:
    """Append the root logger's records to ``path`` too, formatted like its first file
    handler's (Hydra's). A resumed run logs to a new Hydra directory; this keeps the
    resumed trials in the run directory's own train.log. Idempotent."""
    root = logging.getLogger()
    files = [h for h in root.handlers if isinstance(h, logging.FileHandler)]
    target = path.resolve()
    if any(Path(h.baseFilename) == target for h in files):
        return
    handler = logging.FileHandler(target, mode="a", encoding="utf-8")
    if files:
        handler.setFormatter(files[0].formatter)
        handler.setLevel(files[0].level)
    root.addHandler(handler)


class WarningsTo(logging.Handler):
    """Passes records of WARNING and above on to another handler (``target``)."""

    def __init__(self, target: logging.Handler) -> None:
        super().__init__(logging.WARNING)
        self.target = target

    def emit(self, record: logging.LogRecord) -> None:
        self.target.handle(record)


def log_torch_warnings_to_files() -> None:
    """Also write PyTorch's own warnings to the root logger's files (Hydra's train.log).

    PyTorch's loggers (``torch``, ``torch._dynamo``, ``torch._inductor``, ...) do not
    propagate to the root logger, so their warnings (e.g. the compiler's "hit
    config.recompile_limit", after which a step runs eagerly) reach the console only. Call
    this once logging is configured (in a Hydra task function) and torch is imported.
    Only warnings and errors are passed on: some of these loggers log at DEBUG on their
    own (``torch.__trace``, the compiler's structured trace, writes an empty record per
    traced frame — 1690 lines in the first 25 minutes of a Furuta run before this)."""
    files = [h for h in logging.getLogger().handlers if isinstance(h, logging.FileHandler)]
    for name in list(logging.root.manager.loggerDict):
        logger = logging.getLogger(name)
        if (name == "torch" or name.startswith("torch.")) and not logger.propagate:
            for handler in files:
                if not any(getattr(h, "target", None) is handler for h in logger.handlers):
                    logger.addHandler(WarningsTo(handler))
