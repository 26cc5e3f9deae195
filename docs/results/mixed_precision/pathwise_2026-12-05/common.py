"""What the scripts of this folder share: a run's components with the GP of one trial and
the policy of another, and the GP inputs a float64 rollout visits."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import torch

from analysis.evaluate import load_trial
from mcpilco.optim.rollout import ParticleRollout
from mcpilco.run_storage import RunDirectory


def load(run: Path, model_trial: int, policy_trial: int) -> Any:
    """The run's components with trial ``model_trial``'s GP (fitted on trials before it)
    and trial ``policy_trial``'s policy."""
    _, experiment = load_trial(run, model_trial)
    components = experiment.components
    components.policy.load_state_dict(RunDirectory(run).load_checkpoint(policy_trial, "policy"))
    return components


def visited_gp_inputs(c: Any, seed: int = 5) -> torch.Tensor:
    """GP inputs ``[T·400, D]`` of a float64 rollout of 400 particles, no dropout."""
    seen, sample = [], c.model.gp.sample
    c.model.gp.sample = lambda inputs, noise: (seen.append(inputs.detach().clone()), sample(inputs, noise))[1]
    try:
        with torch.no_grad():
            ParticleRollout.for_system(c.system, c.model, c.policy, c.cost, c.estimator)(
                400, 0.0, torch.Generator().manual_seed(seed)
            )
    finally:
        c.model.gp.sample = sample
    return torch.cat(seen, 0)
