"""How many training points the reference code's SoD (relative 0.5 sigma_n, per GP) would keep."""
import sys
from pathlib import Path
import torch
from analysis.evaluate import load_trial

def greedy(gram, noise, thr):
    kept = [0]
    for i in range(1, gram.shape[0]):
        K = gram[kept][:, kept] + noise * torch.eye(len(kept), dtype=gram.dtype)
        k = gram[kept, i]
        var = gram[i, i] - k @ torch.linalg.solve(K, k)
        if var.clamp_min(0).sqrt() > thr:
            kept.append(i)
    return kept

for run in sys.argv[1:]:
    for trial in range(2, 6):
        try:
            _, exp = load_trial(Path(run), trial)
        except SystemExit as e:
            print(run, trial, "skip", e); continue
        gp = exp.components.model.gp
        x = gp.train_inputs
        n = x.shape[0]
        with torch.no_grad():
            gram = gp.kernel(x, x)
        nv = gp.noise_variance.detach()
        per = [len(greedy(gram[g], nv[g], 0.5 * nv[g].sqrt())) for g in range(gram.shape[0])]
        union = set()
        for g in range(gram.shape[0]):
            union |= set(greedy(gram[g], nv[g], 0.5 * nv[g].sqrt()))
        print(run.split("results/")[-1], "T", trial, "n", n, "sigma_n", [f"{float(s):.4f}" for s in nv.sqrt()],
              "kept per GP", per, "union", len(union), flush=True)
