"""Squashed RBF-network policy with weight dropout (thesis §2.4.1, §2.4.3)."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import torch
from torch import nn

from mcpilco.errors import ConfigError
from mcpilco.extension import ExtensionPoint
from mcpilco.moments.rbf import rbf_moments
from mcpilco.moments.trig import sine_saturation
from mcpilco.policies.rbf_network import SquashedRBFFunction, squashed_rbf

ANGLE_CENTRES = ("uniform", "circle")
SQUASHES = ("tanh", "sine")


class SquashedRBFPolicy(ExtensionPoint, nn.Module):
    """π(x) = u_max tanh(Σ_i w_i exp(−‖(a_i − x)/ℓ‖²) / u_max), one output per action.

    One diagonal length-scale vector ℓ is shared by all basis functions. Initialisation
    follows the public reference code: centres uniform in [−centre_range, centre_range]
    (one range for every input column, or one per column), weights uniform in
    [−u_max/2, u_max/2], ℓ = ``lengthscale``. With
    ``angle_centres="circle"`` the centres' (sin θ, cos θ) columns named by
    ``angle_columns`` are drawn on the unit circle instead, (sin a, cos a) with a uniform
    in [−π, π) (as the reference code does for the cart-pole), so each basis function sits
    at an angle the input can reach; ``"uniform"`` treats them like every other column.

    Dropout (only while optimising): each particle drops each basis function (its weights
    for all action components) with probability p_d and scales the kept ones by 1/(1 − p_d).

    Args:
        input_dim: d_π. action_dim: d_u. u_max: action bound.
        num_basis: n_b. lengthscale: initial ℓ.
        centre_range: half-width of the centres' initial range, a number or one per input
            column (e.g. the UR5's narrow ranges for the tracking-error columns: with many
            input columns and ranges much wider than ℓ, every initial activation is ~0 and
            the policy starts with no gradient).
        angle_centres: ``uniform`` or ``circle``, see above.
        angle_columns: (sin column, cos column) pairs of the input (the model structure
            passes them; ignored with ``angle_centres="uniform"``).
        generator: source of the random initialisation.
        squash: ``tanh`` (the thesis's) or ``sine``, PILCO's saturation
            u_max (9 sin z + sin 3z)/8 of z = Σ_i w_i φ_i(x)/u_max, whose moments under a
            Gaussian z are closed-form (``algorithm=pilco`` needs it).
    """

    def __init__(
        self,
        input_dim: int,
        action_dim: int,
        u_max: float,
        num_basis: int = 200,
        lengthscale: float = 1.0,
        centre_range: float | Sequence[float] = math.pi,
        angle_centres: str = "uniform",
        angle_columns: Sequence[tuple[int, int]] = (),
        generator: torch.Generator | None = None,
        squash: str = "tanh",
    ) -> None:
        super().__init__()
        if squash not in SQUASHES:
            raise ConfigError(f"policy.squash must be one of {list(SQUASHES)}, got {squash!r}")
        self.squash = squash
        if angle_centres not in ANGLE_CENTRES:
            raise ConfigError(
                f"policy.angle_centres must be one of {list(ANGLE_CENTRES)}, got {angle_centres!r}"
            )
        columns = [(int(s), int(c)) for s, c in angle_columns]
        flat = [i for pair in columns for i in pair]
        if any(not 0 <= i < input_dim for i in flat) or len(set(flat)) != len(flat):
            raise ConfigError(
                f"policy angle_columns {columns} must be distinct columns of the "
                f"{input_dim}-dimensional policy input"
            )
        self.angle_columns = columns if angle_centres == "circle" else []
        if num_basis < 1:
            raise ConfigError(f"policy.num_basis must be >= 1, got {num_basis}")
        if lengthscale <= 0:
            raise ConfigError(f"policy.lengthscale must be > 0, got {lengthscale}")
        self.u_max = float(u_max)
        self.num_basis = num_basis
        self.initial_lengthscale = lengthscale
        try:
            numbers = centre_range if isinstance(centre_range, (int, float)) else list(centre_range)
            ranges = torch.tensor(numbers, dtype=torch.float64)
        except (TypeError, ValueError):
            ranges = torch.empty(0, 0)
        if ranges.dim() > 1 or (ranges.dim() == 1 and ranges.shape[0] != input_dim):
            raise ConfigError(
                f"policy.centre_range must be a number or {input_dim} numbers (one per policy "
                f"input column), got {centre_range!r}"
            )
        if not bool(torch.all(ranges > 0)):
            raise ConfigError(f"policy.centre_range must be > 0, got {centre_range!r}")
        self.centre_range = ranges
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
        if self.angle_columns:
            sample = torch.rand(
                (self.num_basis, len(self.angle_columns)), generator=generator, dtype=torch.float64
            )
            angles = (2.0 * sample - 1.0) * math.pi
            sin_columns = [s for s, _ in self.angle_columns]
            cos_columns = [c for _, c in self.angle_columns]
            self.centres[:, sin_columns] = angles.sin().to(self.centres)
            self.centres[:, cos_columns] = angles.cos().to(self.centres)
        self.log_lengthscale.fill_(math.log(self.initial_lengthscale))

    def dropout_bits(
        self, steps: int, batch: int, generator: torch.Generator | None
    ) -> torch.Tensor:
        """Uniform random bytes ``[steps, batch, n_b]`` for :meth:`prepare`.

        The bytes of 64-bit random integers drawn on the full int64 range: one generator
        call per rollout instead of one float per mask entry, which dominates the CPU time
        otherwise.
        """
        count = steps * batch * self.num_basis
        draws = torch.empty((count + 7) // 8, dtype=torch.int64, device=self.weights.device)
        # uniform on [-2^63, 2^63 - 1): all eight bytes uniform (bias 2^-64)
        draws.random_(-(2**63), 2**63 - 1, generator=generator)
        return draws.view(torch.uint8)[:count].view(steps, batch, self.num_basis)

    def prepare(
        self, dropout: float = 0.0, dtype: torch.dtype | None = None
    ) -> Callable[..., torch.Tensor]:
        """``act(inputs [M, d_π], bits [M, n_b] | None) ↦ actions [M, d_u]`` with the scaled
        centres and the dropout scaling computed once (call again after every parameter
        update).

        With ``bits`` (from :meth:`dropout_bits`) a basis is dropped when its byte is below
        round(256 p_d), i.e. with probability p_d rounded to a multiple of 1/256 (exact for
        the schedule's 0.25 and 0.125); kept ones are scaled by 1/(1 − p_d). The threshold
        is a tensor, so one compiled graph serves every p_d > 0. ``dtype``: compute in it
        (None: the parameters' dtype); a cast is differentiable, so gradients reach the
        parameters in their own dtype (a float32 rollout of a float64 policy).
        """
        centres, log_lengthscale, raw_weights = (
            p if dtype is None else p.to(dtype)
            for p in (self.centres, self.log_lengthscale, self.weights)
        )
        inverse = torch.exp(-log_lengthscale)
        scaled_centres = centres * inverse  # [n_b, d_π]
        twice_centres_t = (2.0 * scaled_centres).T.contiguous()  # [d_π, n_b]
        centre_offset = -scaled_centres.square().sum(-1)  # [n_b]
        threshold = round(dropout * 256)
        weights = raw_weights / (self.u_max * (1.0 - threshold / 256))
        below = torch.tensor(threshold - 1, dtype=weights.dtype, device=weights.device)
        u_max, masked = self.u_max, threshold > 0  # no int in the closure: one graph
        if self.squash == "sine":

            def act_sine(inputs: torch.Tensor, bits: torch.Tensor | None = None) -> torch.Tensor:
                # plain autograd ops (the tanh path's backward is the fused one)
                keep = None
                if masked and bits is not None:
                    keep = bits.to(inputs.dtype).sub(below).clamp(0.0, 1.0)
                return squashed_rbf(
                    inputs * inverse, twice_centres_t, centre_offset, weights, u_max, "sine", keep
                )

            return act_sine

        def act(inputs: torch.Tensor, bits: torch.Tensor | None = None) -> torch.Tensor:
            return SquashedRBFFunction.apply(
                inputs,
                inverse,
                twice_centres_t,
                centre_offset,
                weights,
                bits if masked else None,
                below,
                u_max,
            )

        return act

    def gaussian_moments(
        self, mean: torch.Tensor, cov: torch.Tensor
    ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        """Moments of the actions for a Gaussian input N(mean ``[d_π]``, cov ``[d_π, d_π]``)
        (``squash="sine"`` only): mean ``[d_u]``, covariance ``[d_u, d_u]`` and ``factor``
        ``[d_π, d_u]`` with Cov(input, u) = cov · factor. Exact: the network before its
        squash is an RBF expansion z(x) = Σ_i β_i exp(−½ (x − c_i)ᵀ Λ⁻¹ (x − c_i)) with
        Λ⁻¹ = 2/ℓ², β = wᵀ/u_max, and the sine saturation has closed-form moments."""
        if self.squash != "sine":
            raise ConfigError(
                f"policy.squash={self.squash!r} has no closed-form moments; use policy.squash=sine"
            )
        inverse_lambda = 2.0 * torch.exp(-2.0 * self.log_lengthscale)
        outputs = self.weights.shape[1]
        z_mean, z_cov, z_factor = rbf_moments(
            self.centres,
            self.weights.T / self.u_max,
            inverse_lambda.expand(outputs, -1),
            torch.ones(outputs, dtype=mean.dtype, device=mean.device),
            mean,
            cov,
        )
        u_mean, u_cov, u_factor = sine_saturation(z_mean, z_cov, self.u_max)
        return u_mean, u_cov, z_factor @ u_factor

    def population_act(self, vectors: torch.Tensor) -> Callable[..., torch.Tensor]:
        """``act(inputs [P·M, d_π], bits=None) ↦ actions [P·M, d_u]`` for P parameter vectors
        ``[P, n_params]`` (laid out as ``parameters_to_vector(self.parameters())``: centres,
        log length-scales, weights): block p of M inputs goes through policy p. No dropout;
        no gradient needed (gradient-free search)."""
        count = vectors.shape[0]
        sizes = [p.numel() for p in self.parameters()]
        centres, log_lengthscale, weights = torch.split(vectors, sizes, dim=1)
        dim, outputs = self.centres.shape[1], self.weights.shape[1]
        inverse = torch.exp(-log_lengthscale)[:, None, :]  # [P, 1, d]
        scaled = centres.view(count, self.num_basis, dim) * inverse  # [P, n_b, d]
        twice_t = 2.0 * scaled.transpose(1, 2)  # [P, d, n_b]
        offset = -scaled.square().sum(-1)[:, None, :]  # [P, 1, n_b]
        scaled_weights = weights.view(count, self.num_basis, outputs) / self.u_max
        u_max, squash = self.u_max, self.squash

        def act(inputs: torch.Tensor, bits: torch.Tensor | None = None) -> torch.Tensor:
            like = inputs.dtype  # the rollout's (float32 in the mixed setting)
            z = inputs.view(count, -1, dim) * inverse.to(like)  # [P, M, d]
            actions = squashed_rbf(
                z, twice_t.to(like), offset.to(like), scaled_weights.to(like), u_max, squash
            )
            return actions.reshape(-1, outputs)

        return act

    def forward(
        self, inputs: torch.Tensor, bits: torch.Tensor | None = None, dropout: float = 0.0
    ) -> torch.Tensor:
        """Actions ``[M, d_u]`` for inputs ``[M, d_π]`` (dropout as in :meth:`prepare`)."""
        return self.prepare(dropout)(inputs, bits)
