"""The costs around the optimisation steps that ``make bench`` times: a whole
``protocol=quick`` run per phase, and what MCAP + Rerun logging adds to a trial."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np


def logging_overhead(
    step_seconds: float, prediction_seconds: float, steps: int = 1500
) -> tuple[float, float]:
    """Seconds that MCAP + Rerun (save) add to one trial of realistic size (M = 400,
    T = 60, ``steps`` optimisation steps, plus the measured no-grad particle rollout for
    the logged prediction), and that as a fraction of the trial's optimisation time."""
    import tempfile

    from mcpilco.systems import CartPole
    from mcpilco.tracking import McapLogger, RerunStreamer
    from mcpilco.tracking.schema import TRACE_KEYS
    from mcpilco.trajectory import Trajectory

    rng = np.random.default_rng(0)
    system = CartPole()
    states = rng.normal(size=(61, 4))
    trajectory = Trajectory(states, states, rng.normal(size=(60, 1)), 0.05)
    particles = rng.normal(size=(61, 400, 4))
    trace = {k: rng.normal(size=steps).tolist() for k in TRACE_KEYS}
    with tempfile.TemporaryDirectory() as folder:
        observers = [
            McapLogger(folder),
            RerunStreamer(folder, mode="save", sketch=system.sketch),
        ]
        start = time.perf_counter()
        for observer in observers:
            observer.run_started({"config": "bench"}, -1)
            observer.model_fitted(1, {"lengthscale": [[1.0] * 6] * 2})
            observer.optimized(1, trace)
            observer.particles_predicted(1, particles, rng.random((61, 400)), 0.05)
            observer.rollout(1, trajectory, rng.random(61), rng.random(61))
            observer.trial_finished(1, {"eval_cost": 1.0, "success": False})
            observer.close()
        seconds = time.perf_counter() - start + prediction_seconds
    return seconds, seconds / (steps * step_seconds)


def whole_run(threads: int | None) -> dict[str, float]:
    """Wall time of a complete ``protocol=quick`` cart-pole run (the real runner, MCAP
    logging on, a temporary run directory) and its phases from the run's summary: the
    exploration rollout, GP fits, policy optimisation, the learned policies' system
    rollouts, logging (MCAP, including its particle prediction), and the rest (process
    start, imports, building, storage)."""
    import subprocess
    import sys
    import tempfile

    import pandas as pd

    with tempfile.TemporaryDirectory() as folder:
        command = [
            sys.executable,
            "-m",
            "runners.train",
            "protocol=quick",
            f"hydra.run.dir={folder}",
        ]
        if threads:
            command.append(f"threads={threads}")
        start = time.perf_counter()
        subprocess.run(command, check=True, capture_output=True, cwd=Path(__file__).parent.parent)
        wall = time.perf_counter() - start
        summary = pd.read_csv(Path(folder) / "summary.csv")
    learned = summary[summary["trial"] >= 1]
    phases = {
        "exploration": float(summary.loc[summary["trial"] == 0, "rollout_seconds"].sum()),
        "model fit": float(learned["fit_seconds"].sum()),
        "policy optimisation": float(learned["optimization_seconds"].sum()),
        "system rollouts": float(learned["rollout_seconds"].sum()),
        "logging": float(summary["logging_seconds"].sum()),
    }
    phases["other"] = wall - sum(phases.values())
    phases["total"] = wall
    return phases
