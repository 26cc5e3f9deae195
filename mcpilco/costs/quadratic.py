"""PILCO's saturating cost on a linear map of the state and its angles' sines and cosines,
with its closed-form expectation under a Gaussian state."""

from __future__ import annotations

import math
from collections.abc import Sequence

import torch

from mcpilco.costs.base import Cost
from mcpilco.errors import ConfigError
from mcpilco.moments.gaussian import JointGaussian


class SaturatingQuadratic(Cost):
    """c(x) = 1 − exp(−½ ‖P z(x) − b‖² / w²), z(x) = [x, sin x_A, cos x_A] for the angle
    components A.

    The cart-pole's evaluation cost (2.17), PILCO's own cost, is P = [[1, 0, 0, 0, L, 0],
    [0, 0, 0, 0, 0, L]], b = [0, −L], w = 0.25 m: ‖P z − b‖² = p² + 2pL sin θ + 2L²(1 + cos θ),
    the squared distance of the pole tip from upright over the cart at p = 0.

    Args:
        angles: indices of the angle components of x (their sin and cos are appended, in this
            order: all sines, then all cosines).
        projection: P ``[k, d_x + 2 |A|]``.
        offset: b ``[k]``.
        width: w.
    """

    def __init__(
        self,
        angles: Sequence[int],
        projection: Sequence[Sequence[float]],
        offset: Sequence[float],
        width: float,
    ) -> None:
        super().__init__()
        if width <= 0:
            raise ConfigError(f"cost.width must be > 0, got {width}")
        matrix = torch.tensor([list(row) for row in projection], dtype=torch.float64)
        target = torch.tensor(list(offset), dtype=torch.float64)
        if matrix.dim() != 2 or target.shape != (matrix.shape[0],):
            raise ConfigError(
                f"cost.projection ({list(matrix.shape)}) and cost.offset ({list(target.shape)}) "
                "must be [k, d_x + 2·len(angles)] and [k]"
            )
        self.angles = [int(a) for a in angles]
        self.register_buffer("projection", matrix)
        self.register_buffer("offset", target)
        self.width = float(width)

    def features(self, states: torch.Tensor) -> torch.Tensor:
        """z(x) ``[..., d_x + 2|A|]`` of states ``[..., d_x]``."""
        angles = states[..., self.angles]
        return torch.cat([states, angles.sin(), angles.cos()], dim=-1)

    def _check_width(self, states: torch.Tensor) -> None:
        if self.projection.shape[1] != states.shape[-1] + 2 * len(self.angles):
            raise ConfigError(
                f"cost.projection has {self.projection.shape[1]} columns, but the state has "
                f"{states.shape[-1]} components and {len(self.angles)} angles"
            )

    def forward(self, states: torch.Tensor) -> torch.Tensor:
        """Cost ``[...]`` of states ``[..., d_x]``."""
        self._check_width(states)
        distance = self.features(states) @ self.projection.T - self.offset
        return 1.0 - torch.exp(-0.5 * distance.square().sum(-1) / self.width**2)

    def expected_gaussian(self, mean: torch.Tensor, cov: torch.Tensor) -> torch.Tensor:
        """E c(x) for x ~ N(mean ``[d_x]``, cov ``[d_x, d_x]``) (0-dim tensor), exact up to
        the Gaussian z(x) of moment matching the sines and cosines (exact moments of z):
        1 − |I + S W|^(−½) exp(−½ mᵀ W (I + S W)⁻¹ m), W = I/w², with m, S the mean and
        covariance of P z − b."""
        self._check_width(mean)
        joint = self.augmented(mean, cov)
        projected = joint.select(self.projection)
        centred = projected.mean - self.offset
        k = centred.shape[0]
        eye = torch.eye(k, dtype=mean.dtype, device=mean.device)
        spread = projected.cov + self.width**2 * eye  # (S + w² I) = w² (I + S W)
        factor = torch.linalg.cholesky(spread)
        solved = torch.cholesky_solve(centred[:, None], factor)[:, 0]
        log_det = 2.0 * torch.log(torch.diagonal(factor)).sum() - 2.0 * k * math.log(self.width)
        return 1.0 - torch.exp(-0.5 * log_det - 0.5 * (centred * solved).sum())

    def augmented(self, mean: torch.Tensor, cov: torch.Tensor) -> JointGaussian:
        """The Gaussian of z(x) = [x, sin x_A, cos x_A] (moments exact)."""
        return JointGaussian(mean, cov).with_trig(self.angles)
