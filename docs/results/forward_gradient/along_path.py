"""Do the two gradients agree all along a real search, not only at its start? One trial of a
run is optimised again from the run's checkpoint with the forward gradient (compiled, as
in a run); every EVERY steps the policy as it then is gets Ĵ and its gradient from both
forms (eager, same draws from a generator of its own, the step's dropout), and their
relative difference and cosine are printed. A form that went wrong only in some states
(far from the data, floored variances, saturated actions) would show there. The rounding
yardstick: the autograd form again with Γ⁻¹ formed by a Cholesky solve against I instead
of ``cholesky_inverse`` (equal up to rounding) — how far rounding alone moves the gradient
at the same point.

    PYTHONPATH=. python docs/results/forward_gradient/along_path.py RUN_COPY TRIAL [EVERY]

RUN_COPY: a copy of a run directory holding trials 0..TRIAL-1 only (it is used as the
run directory of the search and must not be a run you want to keep).
"""

import sys
import time

import torch

from mcpilco.build import build
from mcpilco.optim.policy_optimizer import StepInfo, frozen
from mcpilco.optim.rollout import ParticleRollout
from mcpilco.run_storage import RunDirectory
from mcpilco.safe_config import load_run_config
from mcpilco.trial_loop import TrialLoop

torch.set_num_threads(1)
run_copy, trial = sys.argv[1], int(sys.argv[2])
every = int(sys.argv[3]) if len(sys.argv) > 3 else 25
cfg = load_run_config(run_copy)
cfg.model.gp.forward_gradient = True
cfg.rollout_dtype = None  # the float64 inverse form, where the two forms exist
cfg.threads = 1
experiment = build(cfg)
c = experiment.components
storage = RunDirectory(run_copy)
if storage.finished_trials() != trial - 1:
    sys.exit(f"{run_copy} must hold trials 0..{trial - 1}, holds 0..{storage.finished_trials()}")
loop = TrialLoop(c, storage, experiment.streams, trial)
loop.trajectories = [storage.load_trajectory(k) for k in range(trial)]
if trial >= 2:
    c.policy.load_state_dict(storage.load_checkpoint(trial - 1, "policy"))
try:  # runs from before random states were saved: fresh streams (another draw, same check)
    experiment.streams.restore(storage.load_random_state(trial - 1))
except FileNotFoundError:
    print("no saved random state: the search starts from fresh streams")
loop._learn_model(trial)
gp = c.model.gp
gp.forward_gradient = False
gp.precompute()
autograd_caches = gp._caches
cholesky_inverse = torch.cholesky_inverse


def inverse_by_solve(factor: torch.Tensor) -> torch.Tensor:
    identity = torch.eye(factor.shape[-1], dtype=factor.dtype).expand_as(factor)
    return torch.cholesky_solve(identity, factor)


torch.cholesky_inverse = inverse_by_solve
gp.precompute()
torch.cholesky_inverse = cholesky_inverse
yardstick_caches = gp._caches
gp.forward_gradient = True
gp.precompute()
forward_caches = gp._caches
checker = ParticleRollout.for_system(
    c.system, c.model, c.policy, c.cost, c.estimator, c.simulate_estimator, False, None
)
particles = c.optimizer.num_particles


def objective(dropout: float, seed: int) -> tuple[float, torch.Tensor]:
    """Ĵ and its policy gradient (flattened) on the eager rollout, fixed draws."""
    c.policy.zero_grad(set_to_none=True)
    cost = checker(particles, dropout, torch.Generator().manual_seed(seed)).total_cost
    cost.backward()
    return float(cost.detach()), torch.cat([p.grad.flatten() for p in c.policy.parameters()])


print(f"{run_copy} trial {trial}: n = {gp.train_inputs.shape[0]}, M = {particles}")
print(
    "step  dropout  Ĵ(forward)      Ĵ rel diff  grad rel diff  cosine          |grad|"
    "     yardstick: Ĵ rel diff  grad rel diff"
)
worst = [0.0, 0.0]


def check(info: StepInfo) -> None:
    if info.step % every:
        return
    with frozen(c.model):
        cost_f, grad_f = objective(info.dropout, 1000 + info.step)
        gp._caches = autograd_caches
        try:
            cost_a, grad_a = objective(info.dropout, 1000 + info.step)
            gp._caches = yardstick_caches
            cost_y, grad_y = objective(info.dropout, 1000 + info.step)
        finally:
            gp._caches = forward_caches
    rel = float((grad_f - grad_a).norm() / grad_a.norm())
    cosine = float(torch.dot(grad_f, grad_a) / (grad_f.norm() * grad_a.norm()))
    rel_y = float((grad_y - grad_a).norm() / grad_a.norm())
    worst[:] = max(worst[0], rel), max(worst[1], rel_y)
    print(
        f"{info.step:4d}  {info.dropout:7.4f}  {cost_f:14.10f}  "
        f"{abs(cost_f - cost_a) / abs(cost_a):10.1e}  {rel:13.1e}  {cosine:.12f}  "
        f"{float(grad_a.norm()):.3e}  {abs(cost_y - cost_a) / abs(cost_a):20.1e}  {rel_y:13.1e}",
        flush=True,
    )


started = time.perf_counter()
result = c.optimizer.optimize(loop.rollout, trial, experiment.streams.particles, check)
print(
    f"{result.steps} steps, final Ĵ {result.costs[-1]:.4f}; largest gradient rel diff: "
    f"forward {worst[0]:.1e}, yardstick {worst[1]:.1e} "
    f"({time.perf_counter() - started:.0f} s, beside other processes)"
)
