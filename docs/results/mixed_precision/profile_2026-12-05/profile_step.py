"""Profile compiled optimisation steps (float64 or mixed) at n points, kernel-level names."""
import sys, time, torch
torch.set_num_threads(1)
import torch._inductor.config as ic
ic.cpp.enable_kernel_profile = True
from mcpilco.optim.policy_optimizer import frozen
from mcpilco.optim.rollout import ParticleRollout
from runners.bench import CARTPOLE, fitted_experiment
dtype, n = sys.argv[1], int(sys.argv[2])
dt = ["dtype=float64", "rollout_dtype=float32"] if dtype == "mixed" else ["dtype=float64", "rollout_dtype=null"]
ex = fitted_experiment([*dt, *CARTPOLE, "compile=true"], n); c = ex.components
r = ParticleRollout.for_system(c.system, c.model, c.policy, c.cost, c.estimator, compile=True, dtype=c.rollout_dtype)
opt = torch.optim.Adam(c.policy.parameters(), lr=0.01)
def step():
    opt.zero_grad(set_to_none=True); r(c.optimizer.num_particles, 0.25, ex.streams.particles).total_cost.backward(); opt.step()
with frozen(c.model):
    for _ in range(4): step()
    t = time.perf_counter(); [step() for _ in range(5)]; print(f"{dtype} n={n}: {(time.perf_counter()-t)/5*1e3:.1f} ms/step")
    with torch.profiler.profile(record_shapes=True) as p:
        for _ in range(3): step()
print(p.key_averages(group_by_input_shape=True).table(sort_by="self_cpu_time_total", row_limit=30, max_name_column_width=60, max_shapes_column_width=110))
