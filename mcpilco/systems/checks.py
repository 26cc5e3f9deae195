"""Checks on the values a system is built from and the values it produces."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

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


def non_negative(name: str, value: float | Sequence[float]) -> float | np.ndarray:
    """``value`` (a number or one per component); a one-line :class:`ConfigError` naming
    ``system.<name>`` unless every entry is finite and >= 0 (damping, friction)."""
    try:
        array = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ConfigError(f"system.{name} must be a number >= 0, got {value!r}") from None
    if not np.all(np.isfinite(array)) or np.any(array < 0):
        raise ConfigError(f"system.{name} must be >= 0, got {value!r}")
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
