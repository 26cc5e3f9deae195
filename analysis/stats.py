"""Small statistics for the reports: binomial intervals and the sign test."""

from __future__ import annotations

import math


def wilson_interval(successes: int, total: int, z: float = 1.959964) -> tuple[float, float]:
    """Wilson score interval of a binomial proportion (95 % by default)."""
    if total == 0:
        return (math.nan, math.nan)
    p = successes / total
    denominator = 1 + z * z / total
    centre = (p + z * z / (2 * total)) / denominator
    half = z * math.sqrt(p * (1 - p) / total + z * z / (4 * total * total)) / denominator
    return (max(0.0, centre - half), min(1.0, centre + half))


def sign_test(wins: int, losses: int) -> float:
    """Two-sided exact sign test (binomial, p = ½) of ``wins`` against ``losses`` (ties
    left out): the probability of a split at least this uneven."""
    total = wins + losses
    if total == 0:
        return 1.0
    tail = sum(math.comb(total, i) for i in range(min(wins, losses) + 1)) / 2**total
    return min(1.0, 2 * tail)


def rate_with_interval(rate: float, low: float, high: float) -> str:
    """``80 % [49–94]``: a rate and its interval in whole per cent, for the tables."""
    return f"{100 * rate:.0f} % [{100 * low:.0f}–{100 * high:.0f}]"
