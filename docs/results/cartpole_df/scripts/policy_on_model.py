"""Ĵ of stored policies on one stored model (ad-hoc analysis behind ../README.md).

    python docs/results/cartpole_df/scripts/policy_on_model.py MODEL_RUN TRIAL POLICY_RUN:TRIAL ...

For each policy, simulates 400 particles on MODEL_RUN's GPs of TRIAL (three particle
seeds, no dropout, as the optimiser's rollout) and prints Ĵ (training cost 2.16 summed over
time, mean over particles) and the share of particles with |p| < 0.1 m over the last second.
Runs must share the model and policy structure (same preset).
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import numpy as np
import torch
from omegaconf import OmegaConf

from mcpilco.build import build
from mcpilco.optim.policy_optimizer import frozen
from mcpilco.optim.rollout import ParticleRollout
from mcpilco.run_storage import RunDirectory


def load(run: str, trial: int) -> Any:
    """The run's components with trial ``trial``'s policy and GPs loaded (eager steps)."""
    storage = RunDirectory(Path(run))
    cfg = OmegaConf.load(Path(run) / "config.yaml")
    cfg.compile = False
    components = build(cfg).components  # type: ignore[arg-type]
    components.policy.load_state_dict(storage.load_checkpoint(trial, "policy"))
    components.model.load_gp(storage.load_checkpoint(trial, "model"))
    return components


def main() -> None:
    torch.set_num_threads(1)
    model_run, model_trial, *policies = sys.argv[1:]
    m = load(model_run, int(model_trial))
    for spec in policies:
        run, trial = spec.rsplit(":", 1)
        policy = load(run, int(trial)).policy
        rollout = ParticleRollout.for_system(
            m.system, m.model, policy, m.cost, m.estimator, m.simulate_estimator
        )
        costs, centred = [], []
        for seed in range(3):
            generator = torch.Generator().manual_seed(seed)
            with torch.no_grad(), frozen(m.model):
                states = rollout(400, 0.0, generator).states  # [T+1, M, d_x]
            costs.append(m.cost(states).sum(0).mean().item())
            centred.append((states[-30:, :, 0].abs() < 0.1).all(0).double().mean().item())
        print(  # noqa: T201
            f"policy {spec} on model {model_run}:{model_trial}: Ĵ {np.round(costs, 2)}, "
            f"|p| < 0.1 m over the last second: {np.mean(centred):.2f}"
        )


if __name__ == "__main__":
    main()
