"""Squashed RBF-network policy with weight dropout (thesis §2.4.1, §2.4.3)."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import torch
from torch import nn
from torch.autograd.function import once_differentiable

from mcpilco.errors import ConfigError


class _SquashedRBF(torch.autograd.Function):
    """u_max tanh((mask ⊙ exp(−‖x ⊙ ι − c_i‖²)) W) for inputs x ``[M, d]``, inverse
    length-scales ι ``[d]``, scaled centres c ``[n_b, d]``, weights W ``[n_b, d_u]`` (already
    divided by u_max); the 0/1 mask ``[M, n_b]`` keeps entries whose random byte in
    ``bits`` is at least ``threshold`` (no mask when ``bits`` is None).

    Hand-written backward, one node instead of a dozen: with A the masked activations,
    g_h = g u_max (1 − tanh²) and h = (g_h Wᵀ) ⊙ A: g_W = Aᵀ g_h,
    g_z = 2 (h c − z Σ_i h) for z = x ⊙ ι (so g_x = g_z ⊙ ι, g_ι = Σ_m g_z ⊙ x),
    g_c = 2 (hᵀ z − c Σ_m h). Passes over the ``[M, n_b]`` arrays are in place (recomputing A
    in backward instead of storing it was measured slower).
    """

    @staticmethod
    def activations(
        z: torch.Tensor, centres: torch.Tensor, bits: torch.Tensor | None, threshold: int
    ) -> torch.Tensor:
        """Masked activations A ``[M, n_b]``, computed in place in one fresh buffer."""
        exponent = torch.addmm(-centres.square().sum(-1), z, 2.0 * centres.T)
        exponent.sub_(z.square().sum(-1, keepdim=True))
        activations = exponent.exp_()
        if bits is not None:
            activations.masked_fill_(bits < threshold, 0.0)
        return activations

    @staticmethod
    def forward(
        ctx: Any,
        inputs: torch.Tensor,
        inverse_lengthscale: torch.Tensor,
        centres: torch.Tensor,
        weights: torch.Tensor,
        bits: torch.Tensor | None,
        threshold: int,
        u_max: float,
    ) -> torch.Tensor:
        z = inputs * inverse_lengthscale
        activations = _SquashedRBF.activations(z, centres, bits, threshold)
        squashed = torch.matmul(activations, weights).tanh_()
        ctx.save_for_backward(
            inputs, inverse_lengthscale, z, centres, weights, squashed, activations
        )
        ctx.u_max = u_max
        return squashed * u_max

    @staticmethod
    @once_differentiable
    def backward(ctx: Any, grad: torch.Tensor) -> tuple[torch.Tensor | None, ...]:
        inputs, inverse, z, centres, weights, squashed, activations = ctx.saved_tensors
        grad_hidden = grad * ctx.u_max * (1.0 - squashed.square())  # [M, d_u]
        grad_weights = torch.matmul(activations.T, grad_hidden)
        weighted = torch.matmul(grad_hidden, weights.T).mul_(activations)  # h [M, n_b]
        grad_z = torch.matmul(weighted, centres).sub_(z * weighted.sum(-1, keepdim=True))
        grad_z.mul_(2.0)
        grad_centres = torch.matmul(weighted.T, z).sub_(centres * weighted.sum(0).unsqueeze(-1))
        grad_centres.mul_(2.0)
        grad_inputs = grad_z * inverse if ctx.needs_input_grad[0] else None
        grad_inverse = (grad_z * inputs).sum(0)
        return grad_inputs, grad_inverse, grad_centres, grad_weights, None, None, None


class SquashedRBFPolicy(nn.Module):
    """π(x) = u_max tanh(Σ_i w_i exp(−‖(a_i − x)/ℓ‖²) / u_max), one output per action.

    One diagonal length-scale vector ℓ is shared by all basis functions. Initialisation
    follows the public reference code: centres uniform in [−centre_range, centre_range],
    weights uniform in [−u_max/2, u_max/2], ℓ = ``lengthscale``.

    Dropout (only while optimising): each particle drops each basis function (its weights
    for all action components) with probability p_d and scales the kept ones by 1/(1 − p_d).

    Args:
        input_dim: d_π. action_dim: d_u. u_max: action bound.
        num_basis: n_b. lengthscale: initial ℓ. centre_range: see above.
        generator: source of the random initialisation.
    """

    def __init__(
        self,
        input_dim: int,
        action_dim: int,
        u_max: float,
        num_basis: int = 200,
        lengthscale: float = 1.0,
        centre_range: float = math.pi,
        generator: torch.Generator | None = None,
    ) -> None:
        super().__init__()
        if num_basis < 1:
            raise ConfigError(f"policy.num_basis must be >= 1, got {num_basis}")
        if lengthscale <= 0:
            raise ConfigError(f"policy.lengthscale must be > 0, got {lengthscale}")
        self.u_max = float(u_max)
        self.num_basis = num_basis
        self.initial_lengthscale = lengthscale
        self.centre_range = centre_range
        self.centres = nn.Parameter(torch.empty(num_basis, input_dim, dtype=torch.float64))
        self.log_lengthscale = nn.Parameter(torch.empty(input_dim, dtype=torch.float64))
        self.weights = nn.Parameter(torch.empty(num_basis, action_dim, dtype=torch.float64))
        self.reset_parameters(generator)

    @torch.no_grad()
    def reset_parameters(self, generator: torch.Generator | None = None) -> None:
        """Draw a fresh random initialisation."""
        for parameter, half_width in (
            (self.centres, self.centre_range),
            (self.weights, self.u_max / 2),
        ):
            sample = torch.rand(parameter.shape, generator=generator, dtype=torch.float64)
            parameter.copy_((2.0 * sample - 1.0) * half_width)
        self.log_lengthscale.fill_(math.log(self.initial_lengthscale))

    def dropout_bits(
        self, steps: int, batch: int, generator: torch.Generator | None
    ) -> torch.Tensor:
        """Uniform random bytes ``[steps, batch, n_b]`` for :meth:`prepare`.

        Bytes are cut from 63-bit random integers (7 per draw): one generator call per
        rollout instead of one float per mask entry, which dominates the CPU time otherwise.
        """
        count = steps * batch * self.num_basis
        draws = torch.empty((count + 6) // 7, dtype=torch.int64, device=self.weights.device)
        draws.random_(generator=generator)  # uniform on [0, 2^63)
        low_bytes = draws.view(torch.uint8).view(-1, 8)[:, :7]  # little-endian: top byte < 128
        return low_bytes.reshape(-1)[:count].view(steps, batch, self.num_basis)

    def prepare(self) -> Callable[..., torch.Tensor]:
        """``act(inputs [M, d_π], bits [M, n_b] | None, dropout) ↦ actions [M, d_u]`` with
        the scaled centres computed once (call again after every parameter update).

        With ``bits`` (from :meth:`dropout_bits`) a basis is dropped when its byte is below
        round(256 p_d), i.e. with probability p_d rounded to a multiple of 1/256 (exact for
        the schedule's 0.25 and 0.125); kept ones are scaled by 1/(1 − p_d).
        """
        inverse = torch.exp(-self.log_lengthscale)
        scaled_centres = self.centres * inverse  # [n_b, d_π]
        weights = self.weights / self.u_max

        def act(
            inputs: torch.Tensor, bits: torch.Tensor | None = None, dropout: float = 0.0
        ) -> torch.Tensor:
            threshold = round(dropout * 256) if bits is not None else 0
            scaled_weights = weights if threshold == 0 else weights / (1.0 - threshold / 256)
            return _SquashedRBF.apply(
                inputs,
                inverse,
                scaled_centres,
                scaled_weights,
                bits if threshold else None,
                threshold,
                self.u_max,
            )

        return act

    def forward(
        self, inputs: torch.Tensor, bits: torch.Tensor | None = None, dropout: float = 0.0
    ) -> torch.Tensor:
        """Actions ``[M, d_u]`` for inputs ``[M, d_π]`` (dropout as in :meth:`prepare`)."""
        return self.prepare()(inputs, bits, dropout)
