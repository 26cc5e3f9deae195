"""Is the mixed rollout's gradient the float64 one's in expectation? K draws per precision
(different seeds); difference of the mean gradients against its Monte-Carlo standard error."""
import sys
from pathlib import Path
import torch
from common import load
from mcpilco.optim.policy_optimizer import frozen
from mcpilco.optim.rollout import ParticleRollout

torch.set_num_threads(1)
run = Path(sys.argv[1]); k = int(sys.argv[2]); pol = int(sys.argv[3]); K = int(sys.argv[4])
c = load(run, k, pol)
args = (c.system, c.model, c.policy, c.cost, c.estimator)

def draws(rollout, seeds):
    J, G = [], []
    for s in seeds:
        rollout.policy.zero_grad()
        with frozen(rollout.model):
            r = rollout(400, 0.25, torch.Generator().manual_seed(s)); r.total_cost.backward()
        J.append(float(r.total_cost.detach())); G.append(torch.cat([p.grad.flatten() for p in rollout.policy.parameters()]).clone())
    return torch.tensor(J, dtype=torch.float64), torch.stack(G)

seeds = range(1000, 1000 + K)
J64, G64 = draws(ParticleRollout.for_system(*args), seeds)
J32, G32 = draws(ParticleRollout.for_system(*args, dtype=torch.float32), seeds)
# independent samples: two float64 halves with different seeds for a null reference
J64b, G64b = draws(ParticleRollout.for_system(*args), range(5000, 5000 + K))
def compare(name, Ja, Ga, Jb, Gb, paired):
    dG = Ga.mean(0) - Gb.mean(0)
    if paired:
        se2 = ((Ga - Gb).var(0) / K).sum()
        seJ = float((Ja - Jb).std() / K**0.5)
    else:
        se2 = (Ga.var(0) / K + Gb.var(0) / K).sum()
        seJ = float((Ja.var() / K + Jb.var() / K).sqrt())
    print(f"{name}: |mean dG| {float(dG.norm()):.3e}  MC s.e. {float(se2.sqrt()):.3e}  ratio {float(dG.norm()/se2.sqrt()):.2f}  "
          f"|mean G| {float(Gb.mean(0).norm()):.3e}  cos(means) {float(torch.nn.functional.cosine_similarity(Ga.mean(0), Gb.mean(0), dim=0)):.4f}  "
          f"dJ {float(Ja.mean()-Jb.mean()):+.4f} ± {seJ:.4f}", flush=True)
print(f"{run.name} model T{k} policy T{pol}, {K} draws each, 400 particles, dropout 0.25")
compare("mixed vs float64 (same draws)", J32, G32, J64, G64, True)
compare("float64 vs float64 (other draws)", J64b, G64b, J64, G64, False)
compare("mixed vs float64 (other draws)", J32, G32, J64b, G64b, False)
