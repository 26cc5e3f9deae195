"""Calibration of a finished run's model, computed afterwards from its checkpoints.

``python -m analysis.calibrate RUN_DIR... [--trial K] [--particles 400] [--seed 0]``

For runs logged before the per-trial calibration figures existed (or to recompute them
with more particles): loads trial K's policy and GPs (default: each run's last finished
trial), simulates the policy's particles on that model as the trial loop does after the
optimisation (no dropout; with the simulated online estimator where the run used one),
and compares them with trial K's logged rollout on the system (:mod:`mcpilco.calibration`).
Prints one Markdown row per run and writes ``evaluation/trial_KK_calibration.json``.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import torch

from analysis.evaluate import load_trial
from mcpilco.calibration import calibration
from mcpilco.optim.policy_optimizer import frozen
from mcpilco.optim.rollout import ParticleRollout
from mcpilco.run_storage import RunDirectory


def calibrate(run_dir: Path, trial: int | None, particles: int, seed: int) -> dict[str, float]:
    """Calibration figures of trial ``trial`` of ``run_dir`` (written to its evaluation/)."""
    if particles < 2:
        raise SystemExit(f"--particles={particles} must be at least 2")
    trial, experiment = load_trial(run_dir, trial)
    c = experiment.components
    rollout = ParticleRollout.for_system(
        c.system, c.model, c.policy, c.cost, c.estimator, c.simulate_estimator
    )
    generator = torch.Generator(device=experiment.device).manual_seed(seed)
    with torch.no_grad(), frozen(c.model):
        states = rollout(particles, 0.0, generator).states.cpu().numpy()
    real = RunDirectory(run_dir).load_trajectory(trial).states
    figures = {"trial": trial, **calibration(states, real, c.system.state_names)}
    RunDirectory(run_dir).write_text(
        f"evaluation/trial_{trial:02d}_calibration.json", json.dumps(figures, indent=2)
    )
    return figures


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("runs", nargs="+", type=Path, help="run directories")
    parser.add_argument("--trial", type=int, default=None, help="default: the last finished")
    parser.add_argument("--particles", type=int, default=400)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    rows = []
    for run in args.runs:
        figures = calibrate(run, args.trial, args.particles, args.seed)
        components = [k for k in figures if k.startswith("coverage_") and k != "coverage_mean"]
        rows.append(
            f"| {run} | {figures['trial']} | {figures['coverage_mean']:.2f} | "
            f"{figures['nll_mean']:.2f} | "
            + " ".join(f"{k.removeprefix('coverage_')} {figures[k]:.2f}" for k in components)
            + " |"
        )
    print("| run | trial | coverage | NLL | coverage per component |")  # noqa: T201
    print("|---|---|---|---|---|")  # noqa: T201
    print("\n".join(rows))  # noqa: T201


if __name__ == "__main__":
    main()
