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

import numpy as np
import torch

from analysis.evaluate import load_trial
from mcpilco.optim.policy_optimizer import frozen
from mcpilco.optim.rollout import ParticleRollout
from mcpilco.run_storage import RunDirectory


def main() -> None:
    torch.set_num_threads(1)
    model_run, model_trial, *policies = sys.argv[1:]
    _, experiment = load_trial(Path(model_run), int(model_trial))
    m = experiment.components
    last_second = round(1.0 / m.system.dt)
    rollout = ParticleRollout.for_system(
        m.system, m.model, m.policy, m.cost, m.estimator, m.simulate_estimator
    )
    for spec in policies:
        run, trial = spec.rsplit(":", 1)
        m.policy.load_state_dict(RunDirectory(Path(run)).load_checkpoint(int(trial), "policy"))
        costs, centred = [], []
        for seed in range(3):
            generator = torch.Generator().manual_seed(seed)
            with torch.no_grad(), frozen(m.model):
                states = rollout(400, 0.0, generator).states  # [T+1, M, d_x]
            costs.append(m.cost(states).sum(0).mean().item())
            near = states[-last_second:, :, 0].abs() < 0.1
            centred.append(near.all(0).double().mean().item())
        print(  # noqa: T201
            f"policy {spec} on model {model_run}:{model_trial}: Ĵ {np.round(costs, 2)}, "
            f"|p| < 0.1 m over the last second: {np.mean(centred):.2f}"
        )


if __name__ == "__main__":
    main()
