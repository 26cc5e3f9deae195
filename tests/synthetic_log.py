"""A small MCAP log written through the real logger, with random data, for reader tests."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from mcpilco.tracking import McapLogger
from mcpilco.trajectory import Trajectory


def write_log(run_dir: Path, trials: int, config_yaml: str = "seed: 0", steps: int = 10) -> None:
    """``trials`` trials of ``steps`` samples (4 states, 1 action, 50 particles), each
    ended with ``trial_finished`` (one chunk per trial), then the file is finished."""
    rng = np.random.default_rng(0)
    logger = McapLogger(run_dir)
    logger.run_started({"config": config_yaml}, -1)
    for trial in range(trials):
        states = rng.normal(size=(steps + 1, 4))
        particles = rng.normal(size=(steps + 1, 50, 4))
        logger.particles_predicted(trial, particles, rng.random((steps + 1, 50)), 0.05)
        trajectory = Trajectory(states, states, rng.normal(size=(steps, 1)), 0.05)
        logger.rollout(trial, trajectory, rng.random(steps + 1), rng.random(steps + 1))
        logger.trial_finished(trial, {"eval_cost": float(trial), "success": False})
    logger.close()
