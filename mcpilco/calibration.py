"""How well the model's particle prediction covers what the system then did (per trial)."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

BAND = 0.95
"""Central probability mass of the band a real state should fall into."""


def calibration(
    particles: np.ndarray, real: np.ndarray, names: Sequence[str] = ()
) -> dict[str, float]:
    """Calibration figures of one trial, over the steps t = 1..T' of the real rollout (t = 0
    is the sampled initial state; T' < T where the rollout was cut short, e.g. the ball
    leaving the plate; no step left gives NaN figures).

    Args:
        particles: the final policy's particles on the model ``[T+1, M, d_x]``.
        real: the real rollout's states ``[T'+1, d_x]`` (the same policy on the system),
            T' ≤ T.
        names: a name per state component (``x0``, ``x1``, ... when missing).

    Returns:
        ``coverage_<name>``: fraction of steps where the real state lies inside the particles'
        central 95 % band (empirical 2.5 % and 97.5 % quantiles); ``nll_<name>``: mean over
        steps of the Gaussian negative log-likelihood of the real state under the particles'
        mean and variance (nats; a floor of 1e-12 on the variance); ``coverage_mean``,
        ``nll_mean``: their means over components. A calibrated model covers ≈ 0.95.
    """
    if particles.ndim != 3 or real.ndim != 2 or not 1 <= real.shape[0] <= particles.shape[0]:
        raise ValueError(
            f"calibration needs particles [T+1, M, d] and real [T'+1, d] with T' <= T, got "
            f"{particles.shape} and {real.shape}"
        )
    if particles.shape[2] != real.shape[1]:
        raise ValueError(
            f"particles have {particles.shape[2]} components, the rollout {real.shape[1]}"
        )
    predicted, observed = particles[1 : real.shape[0]], real[1:]
    if observed.shape[0] == 0:
        labels = [short_name(names, i) for i in range(real.shape[1])]
        keys = [f"{kind}_{label}" for kind in ("coverage", "nll") for label in labels]
        return dict.fromkeys([*keys, "coverage_mean", "nll_mean"], math.nan)
    low, high = np.quantile(predicted, [(1 - BAND) / 2, (1 + BAND) / 2], axis=1)
    inside = (observed >= low) & (observed <= high)  # [T, d]
    mean = predicted.mean(axis=1)
    variance = np.maximum(predicted.var(axis=1), 1e-12)
    nll = 0.5 * (np.log(2 * math.pi * variance) + (observed - mean) ** 2 / variance)
    labels = [short_name(names, i) for i in range(real.shape[1])]
    figures: dict[str, float] = {}
    for i, label in enumerate(labels):
        figures[f"coverage_{label}"] = float(inside[:, i].mean())
    for i, label in enumerate(labels):
        figures[f"nll_{label}"] = float(nll[:, i].mean())
    figures["coverage_mean"] = float(inside.mean())
    figures["nll_mean"] = float(nll.mean())
    return figures


def short_name(names: Sequence[str], index: int) -> str:
    """A state component's name without its unit (``"θ [rad]"`` → ``"θ"``); ``x<index>``
    when the system names none."""
    if index >= len(names):
        return f"x{index}"
    return names[index].split(" [")[0].strip() or f"x{index}"
