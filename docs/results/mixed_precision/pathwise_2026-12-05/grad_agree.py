"""Mixed vs float64 cost and policy gradient on a real run's checkpoints: model of trial k
(fitted on trials 0..k-1), policy of trial k-1 (start of trial k's optimisation) and of
trial k (its end); 400 particles, same draws, dropout 0.25, as the tests do."""
import sys
from pathlib import Path
import torch
from common import load
from mcpilco.optim.policy_optimizer import frozen
from mcpilco.optim.rollout import ParticleRollout

torch.set_num_threads(1)
run = Path(sys.argv[1]); trials = [int(t) for t in sys.argv[2].split(",")]

def cost_grad(rollout, seed):
    rollout.policy.zero_grad()
    with frozen(rollout.model):
        r = rollout(400, 0.25, torch.Generator().manual_seed(seed))
        r.total_cost.backward()
    g = torch.cat([p.grad.flatten() for p in rollout.policy.parameters()])
    return float(r.total_cost.detach()), g.clone()

for k in trials:
    for which in (w for w in (k - 1, k) if w >= 1):
        c = load(run, k, which)
        n = c.model.gp.train_inputs.shape[-2]
        args = (c.system, c.model, c.policy, c.cost, c.estimator)
        for seed in (5, 6):
            j64, g64 = cost_grad(ParticleRollout.for_system(*args), seed)
            j32, g32 = cost_grad(ParticleRollout.for_system(*args, dtype=torch.float32), seed)
            # reference for noise: float64 with another seed
            cos = float(torch.nn.functional.cosine_similarity(g32, g64, dim=0))
            print(f"{run.name} model T{k} n={n} policy T{which} seed {seed}: J64 {j64:.4f} J32 {j32:.4f} "
                  f"relJ {abs(j32-j64)/abs(j64):.2e} |dg|/|g| {float((g32-g64).norm()/g64.norm()):.3e} cos {cos:.5f} |g| {float(g64.norm()):.3e}", flush=True)
        # seed-to-seed variation in float64 for scale
        _, g64b = cost_grad(ParticleRollout.for_system(*args), 7)
        print(f"   float64 seed 5 vs 7: |dg|/|g| {float((g64b-g64).norm()/g64.norm()):.3e}", flush=True)
