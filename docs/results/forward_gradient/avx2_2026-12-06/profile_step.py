"""Where the compiled float64 default step (forward gradient, SE speed-integration
cart-pole, M 400, T 60, n_b 200, one thread) spends its time: PyTorch profiler over
``STEPS`` steps after warm-up, ops sorted by self CPU time.

    python profile_step.py N [STEPS]
"""

import sys

import torch

torch.set_num_threads(1)
from torch.profiler import ProfilerActivity, profile  # noqa: E402

from mcpilco.optim.policy_optimizer import frozen  # noqa: E402
from mcpilco.optim.rollout import ParticleRollout  # noqa: E402
from runners.bench import CARTPOLE, fitted_experiment  # noqa: E402

n = int(sys.argv[1])
steps = int(sys.argv[2]) if len(sys.argv) > 2 else 5
overrides = ["dtype=float64", "rollout_dtype=null", *CARTPOLE, "device=cpu", "compile=True"]
experiment = fitted_experiment(overrides, n)
c = experiment.components
rollout = ParticleRollout.for_system(
    c.system, c.model, c.policy, c.cost, c.estimator, compile=True, dtype=c.rollout_dtype
)
optimizer = torch.optim.Adam(c.policy.parameters(), lr=0.01)


def step() -> None:
    optimizer.zero_grad(set_to_none=True)
    rollout(400, 0.25, experiment.streams.particles).total_cost.backward()
    optimizer.step()


with frozen(c.model):
    for _ in range(5):
        step()
    with profile(activities=[ProfilerActivity.CPU], record_shapes=len(sys.argv) > 3) as prof:
        for _ in range(steps):
            step()
table = prof.key_averages().table(sort_by="self_cpu_time_total", row_limit=30, max_name_column_width=70)
print(f"n={n}, {steps} steps profiled (totals are over all of them)")
print(table)
if len(sys.argv) > 3:  # third argument: also by input shape, for the named ops
    names = set(sys.argv[3].split(","))
    rows = [e for e in prof.key_averages(group_by_input_shape=True) if e.key in names]
    rows.sort(key=lambda e: -e.self_cpu_time_total)
    for e in rows[:20]:
        print(f"{e.key:14s} {e.self_cpu_time_total / 1e3 / steps:7.2f} ms/step {e.count // steps:5d} calls/step  {e.input_shapes}")
