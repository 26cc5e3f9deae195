import sys, torch, time
torch.set_num_threads(1)
from hydra import compose, initialize_config_dir
from runners.bench import CONFIG_DIR, CARTPOLE, exploration_data, frozen
from mcpilco.build import build
from mcpilco.optim.rollout import ParticleRollout
n=int(sys.argv[1])
with initialize_config_dir(version_base="1.3", config_dir=CONFIG_DIR):
    cfg = compose("train", overrides=["dtype=float64","rollout_dtype=float32",*CARTPOLE,"compile=True"])
e=build(cfg); c=e.components
s,a=exploration_data(e,n); c.model.fit(s,a)
gp=c.model.gp
if gp.train_inputs.shape[0]!=n:
    gp.set_data(gp.train_inputs[:n],gp.train_targets[:n]); gp.precompute()
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
