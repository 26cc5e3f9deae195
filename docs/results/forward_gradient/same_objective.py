"""Same GP, policy and draws: Ĵ and the policy gradient of a whole rollout through the
first-order sample (gp.forward_gradient=true) against the plain form (false), eager and
compiled, on a cart-pole SE GP of N exploration points.

    PYTHONPATH=. python docs/results/forward_gradient/same_objective.py 180 [DROPOUT]

(DROPOUT: the policy's dropout probability, 0.25 by default as at the start of a search.)
"""

import sys

import torch
from mcpilco.optim.policy_optimizer import frozen
from mcpilco.optim.rollout import ParticleRollout
from runners.bench import CARTPOLE, fitted_experiment

torch.set_num_threads(1)
n = int(sys.argv[1])
dropout = float(sys.argv[2]) if len(sys.argv) > 2 else 0.25
experiment = fitted_experiment(["dtype=float64", "rollout_dtype=null", *CARTPOLE], n)
c = experiment.components


def objective(use_first_order: bool, compile: bool) -> tuple[float, torch.Tensor]:
    c.model.gp.forward_gradient = use_first_order
    c.model.gp.precompute()  # rebuild the prediction cache with or without the form
    rollout = ParticleRollout.for_system(
        c.system, c.model, c.policy, c.cost, c.estimator, compile=compile, dtype=None
    )
    c.policy.zero_grad(set_to_none=True)
    with frozen(c.model):
        cost = rollout(400, dropout, torch.Generator().manual_seed(7)).total_cost
        cost.backward()
    gradient = torch.cat([p.grad.flatten() for p in c.policy.parameters()])
    return float(cost.detach()), gradient


for compile in (False, True):
    cost_new, grad_new = objective(True, compile)
    cost_old, grad_old = objective(False, compile)
    print(
        f"n={n} dropout={dropout} compile={compile}: Ĵ {cost_new:.12g} vs {cost_old:.12g} "
        f"(rel {abs(cost_new - cost_old) / abs(cost_old):.1e}); gradient rel "
        f"{float((grad_new - grad_old).norm() / grad_old.norm()):.1e}"
    )
