"""Exact GP regression, G independent outputs sharing one set of inputs."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import torch
from torch import nn

from mcpilco.errors import ConfigError
from mcpilco.gp.linalg import cholesky_with_jitter
from mcpilco.gp.prediction import (
    VARIANCE_FLOOR,
    mean_and_quadratic,
    posterior_sample,
    solve_matrix,
)
from mcpilco.kernels.base import Kernel, PreparedKernel


@dataclass
class _PredictionCache:
    kernel: PreparedKernel  # x* [M, D] -> (k(x*, X) [G, M, N], k(x*, x*) [G, M])
    solve: torch.Tensor  # [Γ⁻¹ | α]: [G, N, N+1]


class ExactGP(nn.Module):
    """G independent GPs with zero prior mean (thesis eq. 2.3–2.4).

    Args:
        kernel: covariance, batched over the G outputs.
        noise_std: initial observation-noise std σ (one value or one per output).
        noise_std_min: lower bound on σ (keeps Γ well conditioned).
        output_names: a name per output, for messages.
    """

    def __init__(
        self,
        kernel: Kernel,
        noise_std: float | Sequence[float] = 0.1,
        noise_std_min: float = 1e-4,
        output_names: Sequence[str] | None = None,
    ) -> None:
        super().__init__()
        self.kernel = kernel
        outputs = kernel.shape.num_outputs
        initial = torch.as_tensor(noise_std, dtype=torch.float64).flatten()
        if initial.numel() not in (1, outputs) or torch.any(initial <= noise_std_min):
            raise ConfigError(
                f"gp.noise_std must be > noise_std_min={noise_std_min}, got {noise_std}"
            )
        # σ² = σ²_min + exp(raw): unconstrained raw parameter, bounded-below variance.
        self.raw_noise = nn.Parameter(torch.log(initial.expand(outputs) ** 2 - noise_std_min**2))
        self.noise_variance_min = noise_std_min**2
        self.output_names = list(output_names or [f"y{i}" for i in range(outputs)])
        self.register_buffer("train_inputs", torch.zeros(0, kernel.shape.input_dim))
        self.register_buffer("train_targets", torch.zeros(0, outputs))
        self._cache: _PredictionCache | None = None

    @property
    def num_outputs(self) -> int:
        return self.kernel.shape.num_outputs

    @property
    def noise_variance(self) -> torch.Tensor:
        """σ² per output ``[G]``."""
        return self.noise_variance_min + torch.exp(self.raw_noise)

    def set_data(self, inputs: torch.Tensor, targets: torch.Tensor) -> None:
        """Training set: inputs ``[N, D]``, targets ``[N, G]``."""
        if inputs.shape[0] != targets.shape[0] or targets.shape[1] != self.num_outputs:
            raise ValueError(
                f"GP data shapes disagree: {tuple(inputs.shape)}, {tuple(targets.shape)}"
            )
        self.train_inputs = inputs.detach()
        self.train_targets = targets.detach()
        self._cache = None

    def _gram_factor(self) -> torch.Tensor:
        inputs = self.train_inputs
        gram = self.kernel(inputs, inputs)
        gram = gram + torch.diag_embed(self.noise_variance[:, None].expand(-1, inputs.shape[0]))
        return cholesky_with_jitter(gram, f"GP outputs {self.output_names}")

    def negative_log_marginal_likelihood(self) -> torch.Tensor:
        """−log p(y | X) summed over outputs, divided by N (eq. 1.4)."""
        factor = self._gram_factor()  # [G, N, N]
        targets = self.train_targets.T.unsqueeze(-1)  # [G, N, 1]
        whitened = torch.linalg.solve_triangular(factor, targets, upper=False)
        data_fit = 0.5 * whitened.square().sum((-1, -2))
        log_det = torch.log(torch.diagonal(factor, dim1=-2, dim2=-1)).sum(-1)
        n = self.train_inputs.shape[0]
        return (data_fit + log_det + 0.5 * n * math.log(2 * math.pi)).sum() / n

    @torch.no_grad()
    def precompute(self) -> None:
        """Factorise once after fitting; predictions then reuse Γ⁻¹ and α."""
        factor = self._gram_factor()
        inverse_gram = torch.cholesky_inverse(factor)
        alpha = torch.matmul(inverse_gram, self.train_targets.T.unsqueeze(-1)).squeeze(-1)
        self._cache = _PredictionCache(
            self.kernel.prepare(self.train_inputs), solve_matrix(inverse_gram, alpha)
        )

    def posterior_weights(self) -> tuple[torch.Tensor, torch.Tensor]:
        """Γ⁻¹ ``[G, N, N]`` and α = Γ⁻¹ y ``[G, N]`` of the fitted GP (no gradient)."""
        solve = self._prediction_cache().solve
        return solve[..., :-1], solve[..., -1]

    def predict(self, inputs: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """Posterior of the latent function at ``inputs [M, D]``.

        Returns:
            mean ``[G, M]`` and variance ``[G, M]`` (output-major; without observation
            noise).
            Differentiable w.r.t. ``inputs``; hyper-parameters are held fixed.
        """
        cache = self._prediction_cache()
        cross, prior_variance = cache.kernel(inputs)  # [G, M, N], [G, M]
        mean, quadratic = mean_and_quadratic(cross, cache.solve)
        return mean, (prior_variance - quadratic).clamp_min(VARIANCE_FLOOR)

    def sample(self, inputs: torch.Tensor, noise: torch.Tensor) -> torch.Tensor:
        """Reparameterised posterior sample ``mean + std ⊙ noise`` ``[G, M]`` at
        ``inputs [M, D]`` with standard-normal ``noise [G, M]`` (one fused op)."""
        cache = self._prediction_cache()
        cross, prior_variance = cache.kernel(inputs)
        return posterior_sample(cross, prior_variance, cache.solve, noise)

    def _prediction_cache(self) -> _PredictionCache:
        if self._cache is None:
            self.precompute()
        assert self._cache is not None
        return self._cache

    def hyperparameters(self) -> dict[str, list[float]]:
        """Constrained hyper-parameter values by name, for logs."""
        values = {"noise_std": self.noise_variance.sqrt().tolist()}
        for prefix, module in self.kernel.named_modules():
            if isinstance(module, Kernel):
                for name, value in module.constrained_hyperparameters().items():
                    values[f"{prefix}.{name}" if prefix else name] = value.tolist()
        return values
