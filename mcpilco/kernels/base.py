"""Kernel interface.

Every kernel holds one set of hyper-parameters per GP output (``num_outputs = G``) and maps
inputs ``x1 [N1, D]``, ``x2 [N2, D]`` (shared by all outputs) to covariances ``[G, N1, N2]``.
Hyper-parameters are stored unconstrained (logarithms) so any optimiser can move them freely.
Kernels are built from config as partials and completed with a :class:`KernelShape`.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Protocol

import torch
from torch import nn

from mcpilco.errors import ConfigError
from mcpilco.extension import ExtensionPoint
from mcpilco.kernels.first_order import FirstOrderCross

BasisFunction = Callable[[torch.Tensor], torch.Tensor]
"""Maps GP inputs ``[N, D]`` to per-output features ``[G, N, P]``."""

PreparedKernel = Callable[[torch.Tensor], tuple[torch.Tensor, torch.Tensor]]
"""Maps test inputs ``x [M, D]`` to ``(k(x, X) [G, M, N], k(x, x) [G, M])`` for fixed
training inputs X. The cross-covariance is best returned column-major (its memory laid out
as k(X, x) ``[G, N, M]``, i.e. ``.mT`` of a contiguous tensor): the layout in which the
predictions' triangular solves and products take it without a transposing copy (measured:
5–15 % of a particle-rollout step at n = 300) — for a particle batch; a few test points are
better row-major (:func:`cross_product`). Any layout gives the same numbers."""

COLUMN_MAJOR_FROM = 16
"""Batches of at least this many test points get prepared cross-covariances column-major,
fewer get them row-major (:func:`cross_product`). Measured, one thread: from M = 16 on the
column-major product is as fast or faster at rollout shapes (N ≤ 300, float32); at M ≤ 9
the row-major one is as fast or up to 2× faster (N = 5000, float64: the torque
controllers, where no triangular solve follows)."""


def cross_product(training: torch.Tensor, test: torch.Tensor) -> torch.Tensor:
    """test · trainingᵀ ``[G, M, N]`` from ``training [G, N, K]`` and ``test [G, M, K]``, in
    the layout :data:`PreparedKernel` prefers: column-major (computed as training · testᵀ)
    for :data:`COLUMN_MAJOR_FROM` or more test points, row-major for fewer."""
    if test.shape[-2] < COLUMN_MAJOR_FROM:
        return torch.matmul(test, training.mT)
    return torch.matmul(training, test.mT).mT


@dataclass(frozen=True)
class KernelShape:
    """What a kernel needs to know about the model it serves.

    Attributes:
        num_outputs: number of independent GPs G.
        input_dim: GP input dimension D.
        basis: physically-inspired features of each output (for the SP kernel), or None.
    """

    num_outputs: int
    input_dim: int
    basis: BasisFunction | None = None


class Kernel(ExtensionPoint, nn.Module, ABC):
    """A covariance function k(x, x') batched over G outputs."""

    def __init__(self, shape: KernelShape) -> None:
        super().__init__()
        self.shape = shape

    @abstractmethod
    def forward(self, x1: torch.Tensor, x2: torch.Tensor) -> torch.Tensor:
        """Covariance ``[G, N1, N2]`` between ``x1 [N1, D]`` and ``x2 [N2, D]``."""

    @abstractmethod
    def diag(self, x: torch.Tensor) -> torch.Tensor:
        """Prior variances k(x, x) ``[G, N]`` of ``x [N, D]``."""

    def constrained_hyperparameters(self) -> dict[str, torch.Tensor]:
        """This kernel's own hyper-parameter values by name (not its sub-kernels'), for
        logs: exp of every ``log_*`` parameter; kernels with other parametrisations add
        theirs."""
        return {
            name.removeprefix("log_"): torch.exp(parameter)
            for name, parameter in self.named_parameters(recurse=False)
            if name.startswith("log_")
        }

    def prepare(self, x2: torch.Tensor) -> PreparedKernel:
        """``x1 ↦ (k(x1, x2), k(x1, x1) diagonal)`` with everything that depends only on
        ``x2`` and the hyper-parameters computed once (predictions at fixed training
        inputs). The default closes over ``x2`` and returns k(x2, x1)ᵀ (a kernel is
        symmetric; column-major, see :data:`PreparedKernel`); kernels override it where
        it pays."""
        return lambda x1: (self(x2, x1).mT, self.diag(x1))

    def prepare_cross(self, x2: torch.Tensor) -> Callable[[torch.Tensor], torch.Tensor]:
        """``x1 ↦ k(x1, x2) [G, M, N]`` alone (a posterior mean needs no variance); the
        default drops :meth:`prepare`'s diagonal."""
        prepared = self.prepare(x2)
        return lambda x1: prepared(x1)[0]

    affine_columns: tuple[int, ...] = ()
    """Input columns every function of the kernel's space is affine in (a GP mean is then
    affine in them; the GIP kernel: the accelerations)."""

    def step_factors(
        self, x2: torch.Tensor, columns: Sequence[int], steps: Sequence[float]
    ) -> torch.Tensor | None:
        """F ``[G, C, N]`` with k(x + s_c e_c, x2) = k(x, x2) ⊙ F_c for every x whose
        column c is 0 (a unit step along one input costs a product, not a kernel row: the
        inertia columns of :meth:`~mcpilco.control.GPInverseDynamics.components`), or None
        where the kernel has no such form (the default). Constants: no gradient."""
        return None

    def prepare_first_order(self, x2: torch.Tensor) -> FirstOrderCross | None:
        """The cross-covariance at fixed training inputs ``x2`` with its first derivatives
        formed in the forward pass (:mod:`mcpilco.kernels.first_order`), or None where
        the kernel does not offer it (the default: predictions then go through
        autograd). Call under ``torch.no_grad()``: the result holds constants."""
        return None

    def _log_parameter(self, name: str, value: float | Sequence[float], size: int) -> nn.Parameter:
        """A ``[G, size]`` parameter holding log(value), after checking value > 0."""
        try:
            values = torch.as_tensor(value, dtype=torch.float64).flatten()
        except (TypeError, ValueError, RuntimeError):
            values = torch.tensor([math.nan], dtype=torch.float64)
        if values.numel() not in (1, size) or not torch.all((values > 0) & values.isfinite()):
            raise ConfigError(
                f"kernel {type(self).__name__}.{name} must be positive and finite with 1 or "
                f"{size} entries, got {value!r}"
            )
        values = values.expand(size).log()
        return nn.Parameter(values.repeat(self.shape.num_outputs, 1).clone())

    def _flag(self, name: str, value: object) -> bool:
        """``value`` if it is a bool; a one-line :class:`ConfigError` naming it otherwise."""
        if not isinstance(value, bool):
            raise ConfigError(
                f"kernel {type(self).__name__}.{name} must be true or false, got {value!r}"
            )
        return value


class KernelFactory(Protocol):
    """A kernel config after Hydra: call it with the shape to get the kernel."""

    def __call__(self, shape: KernelShape) -> Kernel: ...


def select_dims(x: torch.Tensor, dims: Sequence[int] | None) -> torch.Tensor:
    """Columns ``dims`` of ``x [N, D]`` (all columns when None)."""
    return x if dims is None else x[..., list(dims)]


def check_dims(kernel: str, dims: Sequence[int] | None, input_dim: int) -> int:
    """Validate active dimensions and return how many there are."""
    if dims is None:
        return input_dim
    if len(dims) == 0 or any(d < -input_dim or d >= input_dim for d in dims):
        raise ConfigError(
            f"kernel {kernel}.active_dims={list(dims)} out of range for D={input_dim}"
        )
    return len(dims)


def squared_distances(z1: torch.Tensor, z2: torch.Tensor) -> torch.Tensor:
    """‖z1_i − z2_j‖² ``[..., N1, N2]`` from ``[..., N1, D]``, ``[..., N2, D]`` (one matmul)."""
    cross = torch.matmul(z1, z2.transpose(-1, -2))
    squared = z1.square().sum(-1)[..., :, None] + z2.square().sum(-1)[..., None, :] - 2.0 * cross
    return squared.clamp_min(0.0)
