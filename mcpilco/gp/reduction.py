"""Greedy training-set reduction after hyper-parameter training (thesis §2.3.3)."""

from __future__ import annotations

import torch

from mcpilco.errors import ConfigError
from mcpilco.gp.exact import ExactGP

#: How ``β`` is read: in the units of the targets, or in units of each output's trained
#: noise std (the public reference code's ``"relative"`` SoD mode; its cart-pole scripts use 0.5).
REDUCTION_MODES = ("absolute", "relative")


def check_reduction(threshold: float | None, mode: str) -> None:
    """A one-line :class:`ConfigError` for a bad ``model.reduction_threshold`` or ``_mode``."""
    if mode not in REDUCTION_MODES:
        choices = list(REDUCTION_MODES)
        raise ConfigError(f"model.reduction_mode must be one of {choices}, got {mode!r}")
    if threshold is not None and (
        isinstance(threshold, bool) or not isinstance(threshold, (int, float)) or not threshold > 0
    ):
        raise ConfigError(f"model.reduction_threshold must be > 0 or null, got {threshold!r}")


@torch.no_grad()
def reduction_thresholds(gp: ExactGP, threshold: float, mode: str = "absolute") -> torch.Tensor:
    """Per-output std thresholds ``[G]``: ``β`` itself, or ``β σ_n`` of each output (relative)."""
    check_reduction(threshold, mode)
    noise_std = gp.noise_variance.sqrt()  # [G]
    if mode == "relative":
        return threshold * noise_std
    return torch.full_like(noise_std, float(threshold))


@torch.no_grad()
def reduce_dataset(gp: ExactGP, threshold: float, mode: str = "absolute") -> torch.Tensor:
    """Keep a sample only if the subset kept so far predicts it with std above the threshold.

    Samples are visited in order, starting from the first, and the predictor is updated
    each time one is kept (incremental Cholesky). Outputs share one input set, so a sample
    is kept when *any* output's latent std, given the shared kept set, exceeds that output's
    threshold (the reference code keeps one subset per output).

    Args:
        gp: a fitted GP; its data are replaced by the kept subset (and re-factorised).
        threshold: β, in the units of the targets (``mode="absolute"``) or of each output's
            trained noise std σ_n (``mode="relative"``: keep when latent std > β σ_n).
        mode: ``"absolute"`` or ``"relative"``.
    Returns:
        indices of the kept samples ``[N_r]``.
    """
    limit = reduction_thresholds(gp, threshold, mode).square()  # [G], variance units
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
        if bool(torch.any(latent_variance > limit)):
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
