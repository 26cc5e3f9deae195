"""Greedy training-set reduction after hyper-parameter training (thesis §2.3.3)."""

from __future__ import annotations

import torch

from mcpilco.gp.exact import ExactGP


@torch.no_grad()
def reduce_dataset(gp: ExactGP, threshold: float) -> torch.Tensor:
    """Keep a sample only if the subset kept so far predicts it with std above ``threshold``.

    Samples are visited in order, starting from the first, and the predictor is updated
    each time one is kept (incremental Cholesky). Outputs share one input set, so a sample
    is kept when *any* output's latent std exceeds the threshold.

    Args:
        gp: a fitted GP; its data are replaced by the kept subset (and re-factorised).
        threshold: β, in the units of the targets.
    Returns:
        indices of the kept samples ``[N_r]``.
    """
    inputs, targets = gp.train_inputs, gp.train_targets
    n = inputs.shape[0]
    gram = gp.kernel(inputs, inputs)  # [G, N, N]
    prior_variance = torch.diagonal(gram, dim1=-2, dim2=-1)  # [G, N]
    noise = gp.noise_variance  # [G]
    kept = [0]
    factor = torch.sqrt(prior_variance[:, :1] + noise[:, None]).unsqueeze(-1)  # [G, 1, 1]
    for i in range(1, n):
        cross = gram[:, kept, i].unsqueeze(-1)  # [G, S, 1]
        projected = torch.linalg.solve_triangular(factor, cross, upper=False)  # [G, S, 1]
        explained = projected.square().sum((-1, -2))  # [G]
        latent_variance = prior_variance[:, i] - explained
        if bool(torch.any(latent_variance > threshold**2)):
            diagonal = torch.sqrt((prior_variance[:, i] + noise - explained).clamp_min(1e-12))
            size = len(kept)
            grown = factor.new_zeros(factor.shape[0], size + 1, size + 1)
            grown[:, :size, :size] = factor
            grown[:, size, :size] = projected.squeeze(-1)
            grown[:, size, size] = diagonal
            factor = grown
            kept.append(i)
    index = torch.tensor(kept, device=inputs.device)
    gp.set_data(inputs[index], targets[index])
    gp.precompute()
    return index
