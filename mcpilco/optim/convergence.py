"""When did a policy optimisation stop improving? (How many of its N_opt steps were spent
after the cost it ends with was already reached.)"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

SMOOTHING_STEPS = 20
"""Ĵ of one step is a Monte Carlo estimate with fresh particles (and dropout masks): the
trace is compared through trailing means over this many steps."""


def steps_to_final(
    costs: Sequence[float], tolerance: float = 0.01, window: int = SMOOTHING_STEPS
) -> int | None:
    """Number of steps after which the optimisation was within ``tolerance`` (relative) of the
    cost it ends with.

    Ĵ_final is the mean of the last ``window`` finite costs; the answer is the first step s
    (counted from 1) whose trailing mean over ``window`` steps is ≤ Ĵ_final + tolerance·|Ĵ_final|.
    Everything after s bought less than ``tolerance`` of the final Ĵ. None for an empty
    trace or one without finite costs.

    Args:
        costs: Ĵ per optimisation step, in order (non-finite steps are skipped).
        tolerance: relative distance to Ĵ_final counted as reached (0.01 = 1 %).
        window: trailing-mean length (shorter traces use their whole length).
    """
    values = np.asarray([c for c in costs if np.isfinite(c)], dtype=np.float64)
    if values.size == 0:
        return None
    width = max(1, min(window, values.size))
    cumulative = np.concatenate([[0.0], np.cumsum(values)])
    trailing = (cumulative[width:] - cumulative[:-width]) / width  # ends at steps width..K
    final = trailing[-1]
    reached = np.flatnonzero(trailing <= final + tolerance * abs(final))
    return int(reached[0]) + width
