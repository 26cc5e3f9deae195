"""Prepared cross-covariances that give their own first derivatives in the forward pass.

A GP prediction at M test points (particles) depends on each point only through its row of
k* = k(x*, X) ``[G, M, N]``: the mean k*α and the quadratic k*Γ⁻¹k*ᵀ of point i are
functions of x*_i alone. Their gradients with respect to each point's own kernel features
(a few numbers per point: the scaled inputs of an SE kernel, the basis of a physical one)
can therefore be formed in the forward pass, while k* and Γ⁻¹k* are at hand, as
contractions Σ_j w_ij ∂k_ij/∂f_i ``[G, M, F]``. The backward pass of such a prediction then
only scales that small Jacobian by the incoming gradient: it keeps no ``[G, N, M]`` tensor
between the passes and runs no product over the training set
(:mod:`mcpilco.gp.forward_gradient`).

A kernel offers this through :meth:`~mcpilco.kernels.base.Kernel.prepare_first_order`;
kernels that do not (the default) are predicted through plain autograd.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable
from typing import Any, NamedTuple

import torch

RowFinish = Callable[[torch.Tensor, Any, torch.Tensor], torch.Tensor]
"""``(features [G, M, F], state, folded [G, M, C]) ↦ Σ_j a_j ∂k_ij/∂f_i [G, M, F]`` (see
:class:`RowContraction`; ``state`` as :meth:`FirstOrderCross.covariance` returned it)."""


class RowContraction(NamedTuple):
    """Σ_j a_j ∂k_ij/∂f_i for fixed training-side weights a ``[G, N]`` (the GP's α).

    The GP appends ``columns`` ``[G, N, C]`` to the matrix it multiplies k* with (C may be
    0), so that k*·columns (``folded``, ``[G, M, C]``) comes out of the product it computes
    anyway; ``finish`` turns that (or ``state``) and the features into the contraction.
    Folding needs k* to be this kernel's own covariance: a sum of kernels contracts each
    term from its state instead."""

    columns: torch.Tensor
    finish: RowFinish


class FirstOrderCross(ABC):
    """k(x*, X) at fixed training inputs X together with contractions of its gradient.

    Every tensor here is a constant of the prediction (no autograd graph) except what
    :meth:`features` returns: x* enters only through those features, and autograd carries
    their gradient back to x*.
    """

    @property
    @abstractmethod
    def num_features(self) -> int:
        """F, the number of features per test point and output."""

    @abstractmethod
    def features(self, x1: torch.Tensor) -> torch.Tensor:
        """Features ``[G, M, F]`` of test inputs ``x1 [M, D]`` (differentiable)."""

    @abstractmethod
    def covariance(self, features: torch.Tensor) -> tuple[torch.Tensor, Any]:
        """k(X, x*) ``[G, N, M]`` (contiguous: k* column-major) and whatever
        :meth:`contract` needs again (e.g. a term's own covariance inside a sum)."""

    @abstractmethod
    def prior_variance(self, features: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """k(x*, x*) ``[G, M]`` and its gradient with respect to the features
        ``[G, M, F]``."""

    @abstractmethod
    def contract(
        self, features: torch.Tensor, state: Any, weights_t: torch.Tensor
    ) -> tuple[torch.Tensor, torch.Tensor]:
        """For weights w ``[G, M, N]`` given as ``weights_t`` ``[G, N, M]``: Σ_j w_ij
        ∂k_ij/∂f_i ``[G, M, F]`` and Σ_j w_ij k_ij ``[G, M]``; ``state`` is what
        :meth:`covariance` returned with k."""

    @abstractmethod
    def row_contraction(self, row_weights: torch.Tensor) -> RowContraction:
        """The contraction with weights ``row_weights`` ``[G, N]`` shared by every test
        point (computed once per fitted GP)."""


class LinearInFeatures(FirstOrderCross):
    """k_ij = f_i·(w ⊙ F_j) for features f = ``feature_map(x*)`` ``[G, M, P]`` and the
    training set's F ``[G, N, P]``, w ``[G, 1, P]`` positive (a physically-inspired kernel
    on its basis, a linear kernel on its columns). Linear in f_i: Σ_j w_ij ∂k_ij/∂f_i =
    Σ_j w_ij (w ⊙ F_j), one product over the training set, and Σ_j w_ij k_ij is its dot
    product with f_i."""

    def __init__(
        self,
        feature_map: Callable[[torch.Tensor], torch.Tensor],
        training_features: torch.Tensor,
        weight: torch.Tensor,
    ) -> None:
        self.feature_map = feature_map
        self.weight = weight
        self.weighted = training_features * weight  # w ⊙ F [G, N, P]

    @property
    def num_features(self) -> int:
        return self.weighted.shape[-1]

    def features(self, x1: torch.Tensor) -> torch.Tensor:
        return self.feature_map(x1)

    def covariance(self, features: torch.Tensor) -> tuple[torch.Tensor, None]:
        return torch.matmul(self.weighted, features.mT), None

    def prior_variance(self, features: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        weighted = features * self.weight
        return (weighted * features).sum(-1), 2.0 * weighted

    def contract(
        self, features: torch.Tensor, state: Any, weights_t: torch.Tensor
    ) -> tuple[torch.Tensor, torch.Tensor]:
        gradient = torch.matmul(self.weighted.mT, weights_t).mT.expand_as(features)  # [G, M, P]
        return gradient, torch.linalg.vecdot(gradient, features)

    def row_contraction(self, row_weights: torch.Tensor) -> RowContraction:
        constant = torch.matmul(row_weights.unsqueeze(-2), self.weighted)  # [G, 1, P]

        def finish(features: torch.Tensor, state: Any, folded: torch.Tensor) -> torch.Tensor:
            return constant.expand_as(features)

        return RowContraction(self.weighted[..., :0], finish)
