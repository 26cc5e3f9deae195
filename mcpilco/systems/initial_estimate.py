"""p(x0) of an environment: declared in config, or estimated from seeded resets."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from mcpilco.errors import ConfigError

KEYS = {"distribution", "mean", "std", "estimate_from_resets", "seed"}


@dataclass(frozen=True)
class InitialDistribution:
    """x0 ~ N(mean, diag(std²)) (``normal``) or each component uniform on mean ± std
    (``uniform``); ``source`` says where the numbers come from."""

    distribution: str
    mean: np.ndarray
    std: np.ndarray
    source: str

    def as_dict(self) -> dict[str, Any]:
        return {"distribution": self.distribution, "mean": self.mean.tolist(),
                "std": self.std.tolist(), "source": self.source}  # fmt: skip


def estimate(
    distribution: str, resets: int, seed: int, reset_state: Callable[[int], np.ndarray]
) -> InitialDistribution:
    """p(x0) from ``resets`` starts ``reset_state(s)`` at seeds s drawn from ``seed``:
    the sample mean and std (normal), or the centre and half-width of the range widened
    by (N + 1)/(N − 1), the unbiased range of a uniform distribution (uniform)."""
    seeds = np.random.default_rng(seed).integers(0, 2**31 - 1, size=resets)
    starts = np.stack([np.asarray(reset_state(int(s)), dtype=np.float64) for s in seeds])
    if distribution == "uniform":
        low, high = starts.min(axis=0), starts.max(axis=0)
        half = 0.5 * (high - low) * (resets + 1) / (resets - 1)
        mean, std = 0.5 * (low + high), half
    else:
        mean, std = starts.mean(axis=0), starts.std(axis=0, ddof=1)
    return InitialDistribution(
        distribution, mean, std, f"estimated from {resets} resets (seed {seed})"
    )


def initial_distribution(
    config: Mapping[str, Any], state_dim: int, reset_state: Callable[[int], np.ndarray]
) -> InitialDistribution:
    """p(x0) from ``system.initial``: declared (``mean``, ``std``) or estimated
    (``estimate_from_resets``); a one-line ConfigError naming the key otherwise."""
    unknown = set(config) - KEYS
    if unknown:
        raise ConfigError(
            f"system.initial has unknown keys {sorted(unknown)} (known: {sorted(KEYS)})"
        )
    distribution = config.get("distribution", "normal")
    if distribution not in ("normal", "uniform"):
        raise ConfigError(f"system.initial.distribution={distribution!r} must be normal or uniform")
    resets = config.get("estimate_from_resets")
    declared = config.get("mean") is not None or config.get("std") is not None
    if (resets is None) == (not declared):
        raise ConfigError(
            "system.initial needs either mean and std, or estimate_from_resets (not both)"
        )
    if resets is not None:
        if isinstance(resets, bool) or not isinstance(resets, int) or resets < 2:
            raise ConfigError(
                f"system.initial.estimate_from_resets={resets!r} must be an integer >= 2"
            )
        seed = config.get("seed", 0)
        if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
            raise ConfigError(f"system.initial.seed={seed!r} must be an integer >= 0")
        return estimate(distribution, resets, seed, reset_state)
    values = {}
    for key in ("mean", "std"):
        raw = config.get(key)
        try:
            array = np.broadcast_to(np.asarray(raw, dtype=np.float64), (state_dim,)).copy()
        except (TypeError, ValueError):
            raise ConfigError(
                f"system.initial.{key}={raw!r} needs one value or {state_dim}"
            ) from None
        if not np.all(np.isfinite(array)) or (key == "std" and np.any(array < 0)):
            raise ConfigError(f"system.initial.{key}={raw!r} must be finite (std >= 0)")
        values[key] = array
    return InitialDistribution(distribution, values["mean"], values["std"], "declared")
