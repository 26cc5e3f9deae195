"""Optimal and sub-optimal swing-ups, measured from logged rollouts (thesis §2.5).

The thesis marks two cumulative-cost values "indicatively associated with an optimal and a
sub-optimal swing-up": optimal when the pole oscillates once before reaching the upward
equilibrium, sub-optimal when it oscillates twice — without giving the numbers. We measure
them from the successful rollouts of a sweep: count the pole's swings (sign changes of its
angular velocity) before it first comes within ``tolerance`` of upright; the swing-ups with
the fewest swings are the optimal ones, those with one more the sub-optimal ones, and each
reference value is the median cumulative cost (2.17) of its group.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
from omegaconf import OmegaConf

from mcpilco.run_storage import RunDirectory
from mcpilco.safe_config import locate_class


@dataclass(frozen=True)
class ReferenceCost:
    """Median cumulative cost of the swing-ups with ``swings`` pole swings (``count`` of them)."""

    name: str
    swings: int
    cost: float
    count: int


def pole_swings(
    angle: np.ndarray,
    angular_velocity: np.ndarray,
    tolerance: float = math.radians(20),
    deadband: float = 0.05,
) -> int | None:
    """Sign changes of the angular velocity ``[T+1]`` (rad/s) before the angle ``[T+1]``
    (rad, 0 = hanging) first comes within ``tolerance`` of ±π; None if it never does.
    Velocities below ``deadband`` (the noise of a pole at rest) have no sign."""
    distance = np.abs(np.abs(np.remainder(angle + np.pi, 2 * np.pi) - np.pi) - np.pi)
    upright = np.flatnonzero(distance < tolerance)
    if upright.size == 0:
        return None
    velocity = angular_velocity[: upright[0] + 1]
    moving = np.sign(velocity[np.abs(velocity) >= deadband])
    return int(np.count_nonzero(moving[1:] != moving[:-1]))


def pole_indices(run: str) -> tuple[int, int]:
    """(angle, angular velocity) state indices of the run's pole: the system's last angle."""
    system = OmegaConf.load(f"{run}/config.yaml").system
    cls = locate_class(  # checked, never instantiated; nothing of the run directory runs
        system._target_, "system._target_", untrusted=Path(run)
    )
    angle = cls.angle_indices[-1]
    return angle, cls.velocity_indices[list(cls.position_indices).index(angle)]


def reference_costs(trials: pd.DataFrame) -> list[ReferenceCost]:
    """Optimal and sub-optimal reference values from the successful (run, trial) rows of
    ``trials`` (columns ``run``, ``trial``, ``success``, ``eval_cost``); fewer than two
    entries when the data hold fewer than two swing counts."""
    successful = trials[trials["success"] & (trials["trial"] >= 1)]
    swings, costs = [], []
    for row in successful.itertuples():
        try:
            angle, velocity = pole_indices(str(row.run))
        except (IndexError, ValueError):  # a system without a revolute pole
            continue
        states = RunDirectory(str(row.run)).load_trajectory(int(row.trial)).states
        count = pole_swings(states[:, angle], states[:, velocity])
        if count is not None:
            swings.append(count)
            costs.append(float(row.eval_cost))
    if not swings:
        return []
    frame = pd.DataFrame({"swings": swings, "cost": costs})
    groups = frame.groupby("swings")["cost"]
    medians, sizes = groups.median(), groups.size()
    fewest = int(medians.index.min())
    references = []
    for name, count in (("optimal", fewest), ("sub-optimal", fewest + 1)):
        if count in medians.index:
            references.append(ReferenceCost(name, count, float(medians[count]), int(sizes[count])))
    return references
