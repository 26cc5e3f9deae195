"""Numerically careful linear algebra for kernel matrices."""

from __future__ import annotations

import logging

import torch

from mcpilco.errors import NotPositiveDefiniteError

log = logging.getLogger(__name__)


def cholesky_with_jitter(
    matrix: torch.Tensor,
    what: str,
    initial_jitter: float = 1e-9,
    max_tries: int = 6,
) -> torch.Tensor:
    """Lower Cholesky factor of a batch of symmetric matrices ``[..., N, N]``.

    If a factorisation fails, jitter ``initial_jitter · mean(diag) · 10^k`` (k = 0, 1, …)
    is added to the diagonal of the failing batch members and the factorisation is retried.

    Args:
        matrix: symmetric matrices ``[..., N, N]``.
        what: a name for error messages (e.g. ``"GP outputs [dp, dtheta]"``).
    Raises:
        NotPositiveDefiniteError: still not positive definite at the largest jitter.
    """
    factor, info = torch.linalg.cholesky_ex(matrix)
    if not bool(torch.any(info > 0)):
        return factor
    scale = torch.diagonal(matrix, dim1=-2, dim2=-1).mean(-1).abs().clamp_min(1e-12)
    identity = torch.eye(matrix.shape[-1], dtype=matrix.dtype, device=matrix.device)
    jitter = initial_jitter
    for _ in range(max_tries):
        failed = (info > 0).to(matrix.dtype)[..., None, None]
        shifted = matrix + failed * (jitter * scale)[..., None, None] * identity
        factor, info = torch.linalg.cholesky_ex(shifted)
        if not bool(torch.any(info > 0)):
            log.warning("%s: kernel matrix needed jitter %.1e x mean diagonal", what, jitter)
            return factor
        jitter *= 10.0
    raise NotPositiveDefiniteError(
        f"{what}: kernel matrix is not positive definite, even with jitter "
        f"{jitter / 10.0:.1e} x mean diagonal (dtype {matrix.dtype})"
    )
