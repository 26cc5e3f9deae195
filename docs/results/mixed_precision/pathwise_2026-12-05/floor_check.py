"""Is the mixed/float64 gradient gap the float32 variance floor? float64 rollout with the
float32 precision floor (√n ε32 k**) in place of 1e-12, compared with both."""
import sys
from pathlib import Path
import torch
from common import load
from mcpilco.optim.policy_optimizer import frozen
from mcpilco.optim.rollout import ParticleRollout
import mcpilco.gp.prediction as P

torch.set_num_threads(1)
run = Path(sys.argv[1]); k = int(sys.argv[2]); pol = int(sys.argv[3]); seeds = [int(s) for s in sys.argv[4].split(",")]
c = load(run, k, pol)
args = (c.system, c.model, c.policy, c.cost, c.estimator)
stats = {"n": 0, "below32": 0, "below64": 0}
orig_forward = P._PosteriorSample.forward
mode = {"floor32": False}

def forward(ctx, cross, prior_variance, solve, noise):
    weighted_t, mean, quadratic = P._products(cross, solve)
    variance = prior_variance - quadratic
    floor32 = P.precision_floor(prior_variance.float(), solve.shape[-2]).double()
    stats["n"] += variance.numel(); stats["below32"] += int((variance < floor32).sum()); stats["below64"] += int((variance < P.VARIANCE_FLOOR).sum())
    floor = floor32 if mode["floor32"] else torch.full_like(variance, P.VARIANCE_FLOOR)
    clamped = variance < floor
    std = torch.maximum(variance, floor).sqrt_()
    ctx.save_for_backward(weighted_t, solve, noise, std, clamped)
    return torch.addcmul(mean, std, noise)
P._PosteriorSample.forward = staticmethod(forward)

def cost_grad(rollout, seed):
    rollout.policy.zero_grad()
    with frozen(rollout.model):
        r = rollout(400, 0.25, torch.Generator().manual_seed(seed)); r.total_cost.backward()
    return float(r.total_cost.detach()), torch.cat([p.grad.flatten() for p in rollout.policy.parameters()]).clone()

def rel(a, b): return float((a - b).norm() / b.norm())
def cos(a, b): return float(torch.nn.functional.cosine_similarity(a, b, dim=0))
for seed in seeds:
    mode["floor32"] = False; stats.update(n=0, below32=0, below64=0)
    j64, g64 = cost_grad(ParticleRollout.for_system(*args), seed)
    frac = stats["below32"] / stats["n"]; frac64 = stats["below64"] / stats["n"]
    mode["floor32"] = True
    jf, gf = cost_grad(ParticleRollout.for_system(*args), seed)
    j32, g32 = cost_grad(ParticleRollout.for_system(*args, dtype=torch.float32), seed)
    print(f"{run.name} model T{k} policy T{pol} seed {seed}: below float32 floor {frac:.2%} (below 1e-12 {frac64:.2%}); "
          f"mixed vs f64 rel {rel(g32,g64):.3f} cos {cos(g32,g64):.4f}; f64+floor32 vs f64 rel {rel(gf,g64):.3f} cos {cos(gf,g64):.4f}; "
          f"mixed vs f64+floor32 rel {rel(g32,gf):.3f} cos {cos(g32,gf):.4f}; J {j64:.4f} {jf:.4f} {j32:.4f}", flush=True)
