"""Run a learned policy many times on the system and on its model, count the successes.

``python -m analysis.evaluate RUN_DIR [--trial K] [--runs 400] [--seed 0]``

Loads the run's config, the policy and GP checkpoints of trial K (default: the last
finished trial), then

* runs the policy ``--runs`` times on the system in closed loop (online estimator on the
  real readings, fresh x0 ~ p(x0) each time), and
* simulates ``--runs`` particles on the learned model the way the optimiser saw them
  (with or without the simulated online estimator, as the run was trained),

and applies the system's success criterion to every trajectory (thesis §3.3, Fig. 3.3).
Writes ``evaluation/trial_KK.json`` in the run directory and prints a one-line summary.
"""

from __future__ import annotations

import argparse
import json
import logging
from pathlib import Path
from typing import Any

import numpy as np
import torch
from omegaconf import OmegaConf
from tqdm import tqdm

from mcpilco.build import build
from mcpilco.controller import PolicyController
from mcpilco.optim.policy_optimizer import frozen
from mcpilco.optim.rollout import ParticleRollout
from mcpilco.run_storage import RunDirectory
from mcpilco.trajectory import Trajectory

log = logging.getLogger("mcpilco.evaluate")


def evaluate(run_dir: Path, trial: int | None, runs: int, seed: int) -> dict[str, Any]:
    """Success counts of trial ``trial``'s policy on the system and on the model."""
    storage = RunDirectory(run_dir)
    last = storage.finished_trials()
    trial = last if trial is None else trial
    if not 1 <= trial <= last:
        raise SystemExit(f"--trial={trial}: {run_dir} has learned trials 1..{last}")
    if runs < 1:
        raise SystemExit(f"--runs={runs} must be positive")
    cfg = OmegaConf.load(run_dir / "config.yaml")
    experiment = build(cfg)  # type: ignore[arg-type]
    c = experiment.components
    c.policy.load_state_dict(storage.load_checkpoint(trial, "policy"))
    c.model.load_gp(storage.load_checkpoint(trial, "model"))
    system, rng = c.system, np.random.default_rng(seed)

    system_success = []
    for _ in tqdm(range(runs), desc=f"trial {trial} on the system", unit="run"):
        controller = PolicyController(c.policy, c.model, c.estimator)
        trajectory = system.rollout(
            controller, system.sample_initial_state(rng), system.num_steps, rng
        )
        system_success.append(bool(system.evaluate(trajectory).get("success", False)))

    rollout = ParticleRollout.for_system(
        system, c.model, c.policy, c.cost, c.estimator, c.simulate_estimator
    )
    generator = torch.Generator(device=experiment.device).manual_seed(seed)
    with torch.no_grad(), frozen(c.model):
        particles = rollout(runs, 0.0, generator).states.cpu().numpy()  # [T+1, runs, d_x]
    no_actions = np.zeros((system.num_steps, system.action_dim))
    model_success = [
        bool(
            system.evaluate(Trajectory(states, states, no_actions, system.dt)).get("success", False)
        )
        for states in particles.transpose(1, 0, 2)
    ]
    result = {
        "trial": trial,
        "runs": runs,
        "seed": seed,
        "simulate_estimator": c.simulate_estimator,
        "system_successes": int(sum(system_success)),
        "model_successes": int(sum(model_success)),
    }
    storage.write_text(f"evaluation/trial_{trial:02d}.json", json.dumps(result, indent=2))
    return result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("run_dir", type=Path)
    parser.add_argument("--trial", type=int, default=None, help="default: last finished")
    parser.add_argument("--runs", type=int, default=400)
    parser.add_argument("--seed", type=int, default=0, help="x0, noise and particle seed")
    args = parser.parse_args()
    logging.basicConfig(level=logging.WARNING)
    result = evaluate(args.run_dir, args.trial, args.runs, args.seed)
    print(  # noqa: T201
        f"trial {result['trial']}: system {result['system_successes']}/{result['runs']}, "
        f"model {result['model_successes']}/{result['runs']} successes"
    )


if __name__ == "__main__":
    main()
