"""Which GP output makes the training-set reduction (thesis §2.3.3) keep samples.

Loads a saved GP (``checkpoints/<trial>/model.pt`` of a run directory), redoes the greedy
rule of :mod:`mcpilco.gp.reduction` for each output alone with a plain LU solve (an
independent computation), and reports the SE term of the output that keeps the most —
e.g. a white-noise-like SE term (zero covariance between distinct samples) whose variance
exceeds β² keeps every sample:

    python -m analysis.reduction_probe docs/results/ur5_df/seed_0 trial_03
"""

from __future__ import annotations

import sys
from collections.abc import Callable

import torch
from omegaconf import OmegaConf

from mcpilco.build import build
from mcpilco.gp.reduction import reduce_dataset, reduction_thresholds
from mcpilco.kernels import SquaredExponential


def greedy_kept(gram: torch.Tensor, noise: float, threshold: float) -> int:
    """Samples the greedy rule keeps for one output: gram ``[N, N]`` (latent covariance)."""
    prior = torch.diagonal(gram)
    kept = [0]
    for i in range(1, gram.shape[0]):
        subset = gram[kept][:, kept] + noise * torch.eye(len(kept), dtype=gram.dtype)
        cross = gram[kept, i]
        if prior[i] - cross @ torch.linalg.solve(subset, cross) > threshold**2:
            kept.append(i)
    return len(kept)


def main(run: str, trial: str, write: Callable[[str], object] = sys.stdout.write) -> None:
    torch.set_num_threads(1)
    cfg = OmegaConf.load(f"{run}/config.yaml")
    model = build(cfg).components.model
    state = torch.load(f"{run}/checkpoints/{trial}/model.pt", weights_only=True)
    model.load_gp(state)
    gp = model.gp
    assert gp is not None
    threshold = float(cfg.model.reduction_threshold)
    mode = str(cfg.model.get("reduction_mode", "absolute"))
    inputs = gp.train_inputs
    with torch.no_grad():
        gram = gp.kernel(inputs, inputs)
        noise = gp.noise_variance
        limits = reduction_thresholds(gp, threshold, mode).tolist()
        counts = [greedy_kept(gram[g], float(noise[g]), limits[g]) for g in range(len(noise))]
        write(f"N {inputs.shape[0]}, β {threshold} ({mode}); kept per output alone: {counts}\n")
        write(f"noise variance per output: {[f'{v:.3g}' for v in noise.tolist()]}\n")
        worst = max(range(len(counts)), key=counts.__getitem__)
        terms = getattr(gp.kernel, "terms", [gp.kernel])  # a Sum's terms, or the kernel
        for term in (t for t in terms if isinstance(t, SquaredExponential)):
            se_gram = term(inputs, inputs)[worst]
            off_diagonal = se_gram - torch.diag(torch.diagonal(se_gram))
            lengthscales = sorted(term.log_lengthscale[worst].tolist())[:3]
            write(
                f"output {worst + 1}: SE variance {float(se_gram[0, 0]):.3g}, largest SE "
                f"covariance between distinct samples {float(off_diagonal.abs().max()):.3g}, "
                f"smallest log length-scales {[round(v, 1) for v in lengthscales]}\n"
            )
        write(f"reduce_dataset keeps {len(reduce_dataset(gp, threshold, mode))}\n")


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
