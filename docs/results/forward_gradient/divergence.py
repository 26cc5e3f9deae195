"""Is the parting of two searches rounding or a fault? 12 Adam steps from the same policy,
GP and generator seed, four ways: autograd path eager / compiled, forward gradient eager /
compiled; the particles' cost per step, and each way's relative difference from the
autograd-eager one. Rounding alone (eager against compiled, same path) sets the rate at
which any two ways part.

    PYTHONPATH=. python docs/results/forward_gradient/divergence.py 180
"""

import copy
import sys

import torch
from mcpilco.optim.policy_optimizer import frozen
from mcpilco.optim.rollout import ParticleRollout
from runners.bench import CARTPOLE, fitted_experiment

torch.set_num_threads(1)
n = int(sys.argv[1])
experiment = fitted_experiment(["dtype=float64", "rollout_dtype=null", *CARTPOLE], n)
c = experiment.components
start = copy.deepcopy(c.policy.state_dict())


def trace(forward_gradient: bool, compile: bool, steps: int = 12) -> list[float]:
    c.policy.load_state_dict(start)
    c.model.gp.forward_gradient = forward_gradient
    c.model.gp.precompute()
    rollout = ParticleRollout.for_system(
        c.system, c.model, c.policy, c.cost, c.estimator, compile=compile, dtype=None
    )
    optimizer = torch.optim.Adam(c.policy.parameters(), lr=0.01)
    generator = torch.Generator().manual_seed(11)
    costs = []
    with frozen(c.model):
        for _ in range(steps):
            optimizer.zero_grad(set_to_none=True)
            cost = rollout(400, 0.25, generator).total_cost
            cost.backward()
            optimizer.step()
            costs.append(float(cost.detach()))
    return costs


ways = {
    "autograd eager": trace(False, False),
    "autograd compiled": trace(False, True),
    "forward eager": trace(True, False),
    "forward compiled": trace(True, True),
}
reference = ways["autograd eager"]
for name, costs in ways.items():
    rel = [abs(a - b) / abs(b) for a, b in zip(costs, reference, strict=True)]
    print(f"{name:18s} " + " ".join(f"{r:.0e}" for r in rel))
