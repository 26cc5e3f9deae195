"""Moments of SE-kernel GP posteriors and RBF networks at a Gaussian input (PILCO's gp0)."""

from __future__ import annotations

import torch


def rbf_moments(
    centres: torch.Tensor,
    weights: torch.Tensor,
    inverse_lambda: torch.Tensor,
    signal_variance: torch.Tensor,
    mean: torch.Tensor,
    cov: torch.Tensor,
    inverse_gram: torch.Tensor | None = None,
) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """Exact mean and covariance of f_a(x) = Σ_i β_ai k_a(x, c_i) for x ~ N(mean, cov), with
    k_a(x, c) = α_a² exp(−½ (x − c)ᵀ Λ_a⁻¹ (x − c)), and, with ``inverse_gram``, the GP's
    posterior variance added on the diagonal (E[α_a² − k_aᵀ Γ_a⁻¹ k_a]), as in PILCO.

    Args:
        centres: training inputs / basis centres ``[N, D]``.
        weights: β ``[E, N]`` (Γ⁻¹ y for a GP, the output weights for a network).
        inverse_lambda: diagonal of Λ_a⁻¹ ``[E, D]`` (1/ℓ² for exp(−½ Σ (Δ/ℓ)²)).
        signal_variance: α_a² ``[E]``.
        mean, cov: the input's Gaussian, ``[D]`` and ``[D, D]``.
        inverse_gram: Γ_a⁻¹ ``[E, N, N]`` for a GP's model uncertainty, or None.

    Returns:
        mean ``[E]``, covariance ``[E, E]``, and ``factor`` ``[D, E]`` with
        Cov(x, f) = cov · factor.
    """
    outputs, dim = inverse_lambda.shape
    eye = torch.eye(dim, dtype=mean.dtype, device=mean.device)
    offsets = centres - mean  # ν [N, D]
    # q_ai = α² |S Λ⁻¹ + I|^(-1/2) exp(−½ νᵢᵀ (S + Λ)⁻¹ νᵢ), written with W = Λ^(-1/2):
    # (S + Λ)⁻¹ = W B⁻¹ W and |S Λ⁻¹ + I| = |B| for B = W S W + I (eigenvalues ≥ 1: well
    # conditioned even for length-scales of 10⁶, where S + Λ loses S to rounding).
    root = inverse_lambda.sqrt()  # W [E, D]
    b = cov[None] * root[:, :, None] * root[:, None, :] + eye  # [E, D, D]
    factor_b = torch.linalg.cholesky(b)
    white = offsets.T[None] * root[:, :, None]  # W ν  [E, D, N]
    solved_white = torch.cholesky_solve(white, factor_b)  # B⁻¹ W ν  [E, D, N]
    quad = (white * solved_white).sum(1)  # [E, N]
    log_det = 2.0 * torch.log(torch.diagonal(factor_b, dim1=-2, dim2=-1)).sum(-1)
    q = signal_variance[:, None] * torch.exp(-0.5 * quad - 0.5 * log_det[:, None])  # [E, N]
    weighted = weights * q  # [E, N]
    out_mean = weighted.sum(-1)
    solved = solved_white * root[:, :, None]  # (S + Λ)⁻¹ ν  [E, D, N]
    factor = (solved * weighted[:, None, :]).sum(-1).T  # [D, E]: (S+Λ)⁻¹ Σ β q ν

    # Q_ab,ij = k_a(c_i, m) k_b(c_j, m) |R|^(-1/2) exp(½ zᵀ R⁻¹ S z), z = Λa⁻¹νi + Λb⁻¹νj,
    # for the pairs a ≤ b only (Q_ba = Q_abᵀ). The whole exponent is one batched matmul of
    # augmented rows [Λa⁻¹νi T, row term, 1]·[Λb⁻¹νj, 1, column term], T = R⁻¹ S.
    first, second_index = torch.triu_indices(outputs, outputs, device=mean.device)
    scaled = offsets[None] * inverse_lambda[:, None, :]  # [E, N, D]
    log_k = torch.log(signal_variance)[:, None] - 0.5 * (offsets[None] * scaled).sum(-1)
    pair = inverse_lambda[first] + inverse_lambda[second_index]  # [P, D]
    r = cov[None] * pair[:, None, :] + eye  # S (Λa⁻¹ + Λb⁻¹) + I  [P, D, D]
    t = torch.linalg.solve(r, cov.expand(first.shape[0], dim, dim))  # R⁻¹ S
    t = 0.5 * (t + t.transpose(-1, -2))
    left_scaled, right_scaled = scaled[first], scaled[second_index]  # [P, N, D]
    left = torch.bmm(left_scaled, t)  # [P, N, D]
    log_det_r = torch.linalg.slogdet(r)[1]  # [P]
    row = log_k[first] + 0.5 * (left * left_scaled).sum(-1) - 0.5 * log_det_r[:, None]
    column = log_k[second_index] + 0.5 * (torch.bmm(right_scaled, t) * right_scaled).sum(-1)
    ones = torch.ones_like(row)
    augmented_left = torch.cat([left, row[..., None], ones[..., None]], dim=-1)
    augmented_right = torch.cat([right_scaled, ones[..., None], column[..., None]], dim=-1)
    big_q = torch.exp(torch.bmm(augmented_left, augmented_right.transpose(1, 2)))  # [P, N, N]
    q_beta = torch.bmm(big_q, weights[second_index][..., None])[..., 0]  # [P, N]
    upper = (weights[first] * q_beta).sum(-1)  # β_aᵀ Q_ab β_b  [P]
    second = torch.zeros(outputs, outputs, dtype=mean.dtype, device=mean.device)
    second = second.index_put((first, second_index), upper)
    second = second + torch.triu(second, diagonal=1).T
    out_cov = second - torch.outer(out_mean, out_mean)
    if inverse_gram is not None:
        diagonal_pairs = first == second_index
        diagonal_q = big_q[diagonal_pairs]  # [E, N, N], pairs (a, a) in order of a
        model_var = signal_variance - (inverse_gram * diagonal_q).sum((-1, -2))
        out_cov = out_cov + torch.diag(model_var)
    return out_mean, 0.5 * (out_cov + out_cov.T), factor
