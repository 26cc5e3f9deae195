"""How many training samples the reference code's SoD (relative 0.5 σ_n) keeps of a run's
saved GPs: each GP alone (the reference code's per-GP subsets, `analysis.reduction_probe`'s
recount) and our shared subset (`reduce_dataset`, mode "relative").

    python docs/results/reference_sod/kept.py RUN_DIR ... > kept.txt
"""

import sys
from pathlib import Path

import torch

from analysis.evaluate import load_trial
from analysis.reduction_probe import greedy_kept
from mcpilco.gp.reduction import reduce_dataset, reduction_thresholds

for run in sys.argv[1:]:
    for trial in range(2, 6):
        _, experiment = load_trial(Path(run), trial)
        gp = experiment.components.model.gp
        n = gp.train_inputs.shape[0]
        with torch.no_grad():
            gram = gp.kernel(gp.train_inputs, gp.train_inputs)
            noise = gp.noise_variance.tolist()
        limits = reduction_thresholds(gp, 0.5, "relative").tolist()
        alone = [greedy_kept(gram[g], noise[g], limits[g]) for g in range(len(noise))]
        shared = len(reduce_dataset(gp, 0.5, "relative"))
        name = f"{Path(run).parent.name}/{Path(run).name}"
        print(f"{name} T{trial}: n {n}, kept per GP alone {alone}, shared {shared}", flush=True)
