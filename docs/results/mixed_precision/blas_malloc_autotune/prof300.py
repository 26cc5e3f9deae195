import sys, torch, time
torch.set_num_threads(1)
from runners.bench import CARTPOLE, fitted_experiment, frozen
from mcpilco.optim.rollout import ParticleRollout
n=int(sys.argv[1])
e=fitted_experiment(["dtype=float64","rollout_dtype=float32",*CARTPOLE,"compile=True"], n)
c=e.components
r=ParticleRollout.for_system(c.system,c.model,c.policy,c.cost,c.estimator,compile=True,dtype=c.rollout_dtype)
opt=torch.optim.Adam(c.policy.parameters(),lr=0.01)
def step():
    opt.zero_grad(set_to_none=True); r(400,0.25,e.streams.particles).total_cost.backward(); opt.step()
with frozen(c.model):
    for _ in range(4): step()
    from torch.profiler import profile, ProfilerActivity
    with profile(activities=[ProfilerActivity.CPU]) as p:
        for _ in range(3): step()
print(p.key_averages().table(sort_by="self_cpu_time_total", row_limit=30, max_name_column_width=60))
