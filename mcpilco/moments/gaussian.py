"""A Gaussian over a growing list of variables, extended by moment-matched functions."""

from __future__ import annotations

from dataclasses import dataclass

import torch

from mcpilco.moments.trig import trig_moments


@dataclass(frozen=True)
class Gaussian:
    """N(mean ``[n]``, cov ``[n, n]``)."""

    mean: torch.Tensor
    cov: torch.Tensor

    def select(self, selector: torch.Tensor) -> Gaussian:
        """The Gaussian of ``selector @ x`` (``selector`` ``[k, n]``, any linear map)."""
        cov = selector @ self.cov @ selector.T
        return Gaussian(selector @ self.mean, 0.5 * (cov + cov.T))


@dataclass(frozen=True)
class JointGaussian(Gaussian):
    """A joint Gaussian of several variables that :meth:`extend` appends to."""

    def extend(
        self,
        selector: torch.Tensor,
        out_mean: torch.Tensor,
        out_cov: torch.Tensor,
        factor: torch.Tensor,
    ) -> JointGaussian:
        """Append y ``[m]`` = f(input), input = ``selector @ x`` ``[k]``, whose moment-matched
        mean ``[m]``, covariance ``[m, m]`` and ``factor`` ``[k, m]`` (Cov(z, y) =
        Cov(z, input) · factor for every z jointly Gaussian with the input) are given:
        Cov(x, y) = cov selectorᵀ factor."""
        cross = self.cov @ selector.T @ factor  # [n, m]
        cov = torch.cat(
            [torch.cat([self.cov, cross], dim=1), torch.cat([cross.T, out_cov], dim=1)], dim=0
        )
        return JointGaussian(torch.cat([self.mean, out_mean]), cov)

    def with_trig(self, indices: list[int]) -> JointGaussian:
        """Append [sin x_I, cos x_I] of the components ``indices`` (exact moments, cross-
        covariances by Stein's lemma): [x, sin x_I, cos x_I]; unchanged without indices."""
        if not indices:
            return self
        pick = selection(self.mean.shape[0], indices, self.mean)
        angles = self.select(pick)
        return self.extend(pick, *trig_moments(angles.mean, angles.cov))

    def head(self, size: int) -> Gaussian:
        """The marginal of the first ``size`` variables."""
        return Gaussian(self.mean[:size], self.cov[:size, :size])


def selection(total: int, rows: list[int], like: torch.Tensor) -> torch.Tensor:
    """``[len(rows), total]`` 0/1 matrix picking entries ``rows`` of a ``[total]`` vector."""
    matrix = torch.zeros(len(rows), total, dtype=like.dtype, device=like.device)
    matrix[range(len(rows)), rows] = 1.0
    return matrix
