"""Checks on the values a component is built from and the values it produces: one-line
:class:`ConfigError` naming the key and the value, before any work (used by the systems,
the robots, the cloth, the latent models and the runners' own keys)."""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from omegaconf import ListConfig

from mcpilco.errors import ConfigError, NonFiniteError


def positive(name: str, value: float, group: str = "system") -> float:
    """``value`` as a float; a one-line :class:`ConfigError` naming ``<group>.<name>``
    unless it is finite and > 0 (masses, lengths, inertias, time steps, gains)."""
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise ConfigError(f"{group}.{name} must be a positive number, got {value!r}") from None
    if not np.isfinite(number) or number <= 0:
        raise ConfigError(f"{group}.{name} must be positive, got {value!r}")
    return number


def non_negative(
    name: str, value: float | Sequence[float], group: str = "system"
) -> float | np.ndarray:
    """``value`` (a number or one per component); a one-line :class:`ConfigError` naming
    ``<group>.<name>`` unless every entry is finite and >= 0 (damping, friction)."""
    try:
        array = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ConfigError(f"{group}.{name} must be a number >= 0, got {value!r}") from None
    if not np.all(np.isfinite(array)) or np.any(array < 0):
        raise ConfigError(f"{group}.{name} must be >= 0, got {value!r}")
    return float(array) if array.ndim == 0 else array


def require_finite(
    values: np.ndarray, what: str, step: int | None, names: Sequence[str] = ()
) -> None:
    """Raise :class:`NonFiniteError` naming ``step`` (unless None) and the first component
    of ``values`` ``[d]`` that is NaN or infinite (with its label from ``names``)."""
    bad = np.flatnonzero(~np.isfinite(values))
    if bad.size == 0:
        return
    index = int(bad[0])
    label = f" ({names[index]})" if index < len(names) else ""
    raise NonFiniteError(
        ("" if step is None else f"step {step}: ")
        + f"{what} component {index}{label} is {float(values[index])}"
        + (f" ({bad.size} components not finite)" if bad.size > 1 else "")
    )


# ------------------------------------------------------------------ config values by key
# Each takes the full dotted key (``data.duration``) and returns the value checked; the
# error is one line naming the key and the value, raised before any work.
def _is_number(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool)


def number(
    key: str,
    value: Any,
    *,
    minimum: float | None = None,
    maximum: float | None = None,
    above: float | None = None,
) -> float:
    """A finite number within ``[minimum, maximum]`` (and ``> above``)."""
    if not _is_number(value) or not math.isfinite(value):
        raise ConfigError(f"{key}={value!r} must be a finite number")
    if minimum is not None and value < minimum:
        raise ConfigError(f"{key}={value!r} must be >= {minimum:g}")
    if above is not None and value <= above:
        raise ConfigError(f"{key}={value!r} must be > {above:g}")
    if maximum is not None and value > maximum:
        raise ConfigError(f"{key}={value!r} must be <= {maximum:g}")
    return float(value)


def integer(key: str, value: Any, *, minimum: int = 0, maximum: int | None = None) -> int:
    """An integer (not a bool, not a float) within ``[minimum, maximum]``."""
    wanted = {0: "a non-negative integer", 1: "a positive integer"}.get(
        minimum, f"an integer >= {minimum}"
    )
    if maximum is not None:
        wanted += f" <= {maximum}"
    if not isinstance(value, int) or isinstance(value, bool):
        raise ConfigError(f"{key}={value!r} must be {wanted}")
    if value < minimum or (maximum is not None and value > maximum):
        raise ConfigError(f"{key}={value!r} must be {wanted}")
    return value


def optional_integer(key: str, value: Any, *, minimum: int = 1) -> int | None:
    """None, or an integer >= ``minimum``."""
    return None if value is None else integer(key, value, minimum=minimum)


def boolean(key: str, value: Any) -> bool:
    if not isinstance(value, bool):
        raise ConfigError(f"{key}={value!r} must be true or false")
    return value


def choice(key: str, value: Any, options: Sequence[str]) -> str:
    if value not in options:
        raise ConfigError(f"{key}={value!r} must be one of {', '.join(options)}")
    return str(value)


def numbers(
    key: str, value: Any, *, length: int | None = None, minimum: float | None = None
) -> list[float]:
    """A list of finite numbers (``length`` of them, each >= ``minimum``)."""
    if isinstance(value, str | bytes) or not isinstance(value, Sequence | ListConfig):
        raise ConfigError(f"{key}={value!r} must be a list of numbers")
    items = list(value)
    if length is not None and len(items) != length:
        raise ConfigError(f"{key}={items!r} must have {length} entries, it has {len(items)}")
    return [number(f"{key}[{i}]", item, minimum=minimum) for i, item in enumerate(items)]


def text(key: str, value: Any) -> str:
    """A non-empty string."""
    if not isinstance(value, str) or not value.strip():
        raise ConfigError(f"{key}={value!r} must be a non-empty string")
    return value


def writable_directory(key: str, value: Any) -> Path:
    """A directory that is writable, or can be made (its nearest existing ancestor is a
    writable directory); nothing is created."""
    path = Path(text(key, value)).expanduser().absolute()
    existing = path
    while not existing.exists() and existing != existing.parent:
        existing = existing.parent
    if not existing.is_dir():
        raise ConfigError(f"{key}={str(value)!r}: {existing} is not a directory")
    if not os.access(existing, os.W_OK | os.X_OK):
        raise ConfigError(f"{key}={str(value)!r} is not writable ({existing} is read-only here)")
    return path


def fits_in_memory(keys: str, needed_bytes: float, what: str) -> None:
    """A one-line :class:`ConfigError` naming ``keys`` and the estimate when ``what``
    needs more memory than this process may use (:func:`available_bytes`)."""
    limit = available_bytes()
    if needed_bytes > limit:
        raise ConfigError(
            f"{keys}: {what} needs about {needed_bytes / 2**30:.3g} GiB, more than the "
            f"{limit / 2**30:.3g} GiB this process may use"
        )


def available_bytes() -> int:
    """The memory this process may use: the smallest of physical memory, the cgroup's
    limit and ``RLIMIT_AS`` (where the platform tells)."""
    limits = []
    try:
        limits.append(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES"))
    except (ValueError, OSError, AttributeError):
        pass
    for cgroup in ("/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory/memory.limit_in_bytes"):
        try:
            limits.append(int(Path(cgroup).read_text().strip()))
        except (OSError, ValueError):
            pass
    try:
        import resource

        soft, _ = resource.getrlimit(resource.RLIMIT_AS)
        if soft != resource.RLIM_INFINITY:
            limits.append(soft)
    except (ImportError, ValueError, OSError):
        pass
    return min(limits) if limits else 1 << 62
