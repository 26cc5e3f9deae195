"""Is the gradient itself this sensitive? float64 rollout with the policy parameters rounded
to float32 (a 6e-8 relative change), against float64 and mixed, same draws."""
import sys
from pathlib import Path
import torch
from common import load
from mcpilco.optim.policy_optimizer import frozen
from mcpilco.optim.rollout import ParticleRollout

torch.set_num_threads(1)
run = Path(sys.argv[1]); k = int(sys.argv[2]); pol = int(sys.argv[3]); seeds = [int(s) for s in sys.argv[4].split(",")]
c = load(run, k, pol)
state = {name: value.clone() for name, value in c.policy.state_dict().items()}
args = (c.system, c.model, c.policy, c.cost, c.estimator)

def cost_grad(rollout, seed, per_step=False):
    rollout.policy.zero_grad()
    with frozen(rollout.model):
        r = rollout(400, 0.25, torch.Generator().manual_seed(seed)); r.total_cost.backward()
    return float(r.total_cost.detach()), torch.cat([p.grad.flatten() for p in rollout.policy.parameters()]).clone(), r

def rel(a, b): return float((a - b).norm() / b.norm())
def cos(a, b): return float(torch.nn.functional.cosine_similarity(a, b, dim=0))
for seed in seeds:
    c.policy.load_state_dict(state)
    j64, g64, r64 = cost_grad(ParticleRollout.for_system(*args), seed)
    j32, g32, r32 = cost_grad(ParticleRollout.for_system(*args, dtype=torch.float32), seed)
    with torch.no_grad():
        gen = torch.Generator().manual_seed(1)
        for p in c.policy.parameters(): p.mul_(1 + float(sys.argv[5]) * torch.randn(p.shape, generator=gen, dtype=p.dtype))
    jr, gr, rr = cost_grad(ParticleRollout.for_system(*args), seed)
    s64, s32, sr = r64.states.detach(), r32.states.detach(), rr.states.detach()
    # particle divergence at the last step: how many particles end > 0.1 apart (any state)
    d32 = (s32 - s64).abs().amax(-1)[-1] if s64.dim() == 3 else None
    dr = (sr - s64).abs().amax(-1)[-1] if s64.dim() == 3 else None
    print(f"{run.name} model T{k} policy T{pol} seed {seed}: mixed vs f64 rel {rel(g32,g64):.3f} cos {cos(g32,g64):.4f} | "
          f"f64(policy x (1 + e N(0,1))) vs f64 rel {rel(gr,g64):.3f} cos {cos(gr,g64):.4f} | J {j64:.4f} {j32:.4f} {jr:.4f} | states {tuple(s64.shape)}"
          + (f" | particles >0.1 apart at the end: mixed {int((d32>0.1).sum())} rounded {int((dr>0.1).sum())}" if d32 is not None else ""), flush=True)
    d = (s32 - s64).abs().amax(-1)  # [T+1, M]
    dp = (sr - s64).abs().amax(-1)
    for t in range(0, d.shape[0], 4):
        print(f"  t={t:2d} mixed median {float(d[t].median()):.1e} max {float(d[t].max()):.1e} | perturbed median {float(dp[t].median()):.1e} max {float(dp[t].max()):.1e}")
