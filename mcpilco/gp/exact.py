"""Exact GP regression, G independent outputs sharing one set of inputs."""

from __future__ import annotations

import copy
import math
from collections.abc import Sequence
from dataclasses import dataclass

import torch
from torch import nn

from mcpilco.errors import ConfigError
from mcpilco.extension import ExtensionPoint
from mcpilco.gp.forward_gradient import FirstOrderForm
from mcpilco.gp.linalg import cholesky_with_jitter
from mcpilco.gp.prediction import (
    VARIANCE_FLOOR,
    mean_and_quadratic,
    posterior_sample,
    precision_floor,
    solve_matrix,
    whitened_mean_and_quadratic,
    whitened_posterior_sample,
)
from mcpilco.kernels.base import Kernel, PreparedKernel

WHITENED_DTYPES = (torch.float32, torch.float16, torch.bfloat16)
"""Predictions in these dtypes use the whitened form (see :mod:`mcpilco.gp.prediction`)."""


@dataclass
class _PredictionCache:
    """What predictions at fixed training data reuse, in one dtype: either the inverse form
    (``solve`` = [Γ⁻¹ | α] ``[G, N, N+1]``, float64) or the whitened form (``factor`` L
    ``[G, N, N]`` and ``whitened_targets`` β = L⁻¹ y ``[G, N]``, float32)."""

    kernel: PreparedKernel  # x* [M, D] -> (k(x*, X) [G, M, N], k(x*, x*) [G, M])
    solve: torch.Tensor | None = None
    # inverse form with a kernel that forms its own derivatives: samples with a gradient
    # go through it (mcpilco.gp.forward_gradient); ``solve`` is then a view of its matrix
    first_order: FirstOrderForm | None = None
    # L and Lᵀ, each stored contiguous: MKL's float32 solve is faster with the operand
    # contiguous than with a transposed view (forward, Lᵀ: 1.15 vs 1.22 ms; backward, L:
    # 1.17 vs 1.21 ms at N = 300, M = 400, one thread), so both are kept
    factor: torch.Tensor | None = None
    upper_factor: torch.Tensor | None = None
    whitened_targets: torch.Tensor | None = None

    def mean_and_variance(self, inputs: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """Posterior mean and floored variance ``[G, M]`` at ``inputs [M, D]``."""
        cross, prior_variance = self.kernel(inputs)  # [G, M, N], [G, M]
        if self.solve is not None:
            mean, quadratic = mean_and_quadratic(cross, self.solve)
            return mean, (prior_variance - quadratic).clamp_min(VARIANCE_FLOOR)
        assert self.upper_factor is not None and self.whitened_targets is not None
        mean, quadratic = whitened_mean_and_quadratic(
            cross, self.upper_factor, self.whitened_targets
        )
        floor = precision_floor(prior_variance, self.upper_factor.shape[-1])
        return mean, torch.maximum(prior_variance - quadratic, floor)

    def sample(self, inputs: torch.Tensor, noise: torch.Tensor) -> torch.Tensor:
        """Reparameterised posterior sample ``[G, M]`` at ``inputs [M, D]``: through the
        first-order form (:mod:`mcpilco.gp.forward_gradient`) when the kernel offers it and
        a gradient is being taken, else through :func:`posterior_sample` (no gradient, or
        a kernel without it) or the whitened form (float32)."""
        if self.first_order is not None and torch.is_grad_enabled() and inputs.requires_grad:
            return self.first_order.sample(inputs, noise)
        cross, prior_variance = self.kernel(inputs)
        if self.solve is not None:
            return posterior_sample(cross, prior_variance, self.solve, noise)
        assert self.factor is not None and self.upper_factor is not None
        assert self.whitened_targets is not None
        return whitened_posterior_sample(
            cross, prior_variance, self.factor, self.upper_factor, self.whitened_targets, noise
        )


class ExactGP(ExtensionPoint, nn.Module):
    """G independent GPs with zero prior mean (thesis eq. 2.3–2.4).

    Args:
        kernel: covariance, batched over the G outputs.
        noise_std: initial observation-noise std σ (one value or one per output).
        noise_std_min: lower bound on σ (keeps Γ well conditioned).
        output_names: a name per output, for messages.
        forward_gradient: samples taken with a gradient (particle rollouts) form it in the
            forward pass where the kernel offers that (:mod:`mcpilco.gp.forward_gradient`;
            float64 inverse form); False (this constructor's default): through autograd.
            Same numbers to rounding, 15–21 % faster steps; the model configs
            (``conf/model/*.yaml``) turn it on (``docs/results/forward_gradient/``).
    """

    def __init__(
        self,
        kernel: Kernel,
        noise_std: float | Sequence[float] = 0.1,
        noise_std_min: float = 1e-4,
        output_names: Sequence[str] | None = None,
        forward_gradient: bool = False,
    ) -> None:
        super().__init__()
        self.kernel = kernel
        if not isinstance(forward_gradient, bool):
            raise ConfigError(
                f"gp.forward_gradient must be true or false, got {forward_gradient!r}"
            )
        self.forward_gradient = forward_gradient
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
        self._caches: dict[torch.dtype, _PredictionCache] = {}
        self._factor: torch.Tensor | None = None  # Cholesky factor of Γ, from precompute

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
        self._caches = {}
        self._factor = None

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
        """Factorise once after fitting (in the GP's own dtype); predictions then reuse it.
        Predictions in another dtype (a float32 rollout of a float64 GP) get their cache
        from this factorisation, cast (:meth:`_prediction_cache`)."""
        dtype = self.train_inputs.dtype
        self._factor = self._gram_factor()
        self._caches = {dtype: self._cache_from(self._factor, self.kernel, dtype)}

    def _cache_from(
        self, factor: torch.Tensor, kernel: Kernel, dtype: torch.dtype
    ) -> _PredictionCache:
        """The prediction cache in ``dtype`` from the Cholesky factor of Γ (any dtype) and a
        kernel already in ``dtype``."""
        targets = self.train_targets.T.unsqueeze(-1).to(factor.dtype)  # [G, N, 1]
        prepared = kernel.prepare(self.train_inputs.to(dtype))
        if dtype in WHITENED_DTYPES:
            whitened = torch.linalg.solve_triangular(factor, targets, upper=False).squeeze(-1)
            return _PredictionCache(
                prepared,
                factor=factor.to(dtype).contiguous(),
                upper_factor=factor.mT.to(dtype).contiguous(),
                whitened_targets=whitened.to(dtype).contiguous(),
            )
        inverse_gram = torch.cholesky_inverse(factor)
        alpha = torch.matmul(inverse_gram, targets).squeeze(-1)
        solve = solve_matrix(inverse_gram, alpha).to(dtype)
        first_order = (
            kernel.prepare_first_order(self.train_inputs.to(dtype))
            if self.forward_gradient
            else None
        )
        if first_order is None:
            return _PredictionCache(prepared, solve=solve)
        form = FirstOrderForm.from_solve(first_order, solve)
        return _PredictionCache(prepared, solve=form.solve, first_order=form)

    def posterior_weights(self) -> tuple[torch.Tensor, torch.Tensor]:
        """Γ⁻¹ ``[G, N, N]`` and α = Γ⁻¹ y ``[G, N]`` of the fitted GP (no gradient)."""
        cache = self._prediction_cache(self.train_inputs.dtype)
        if cache.solve is not None:
            return cache.solve[..., :-1], cache.solve[..., -1]
        assert cache.factor is not None and cache.whitened_targets is not None
        alpha = torch.linalg.solve_triangular(
            cache.factor.mT, cache.whitened_targets.unsqueeze(-1), upper=True
        )
        return torch.cholesky_inverse(cache.factor), alpha.squeeze(-1)

    def predict(self, inputs: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """Posterior of the latent function at ``inputs [M, D]``, computed in their dtype.

        Returns:
            mean ``[G, M]`` and variance ``[G, M]`` (output-major; without observation
            noise).
            Differentiable w.r.t. ``inputs``; hyper-parameters are held fixed.
        """
        return self._prediction_cache(inputs.dtype).mean_and_variance(inputs)

    def sample(self, inputs: torch.Tensor, noise: torch.Tensor) -> torch.Tensor:
        """Reparameterised posterior sample ``mean + std ⊙ noise`` ``[G, M]`` at
        ``inputs [M, D]`` with standard-normal ``noise [G, M]`` (one fused op), computed in
        the inputs' dtype (float64: inverse form; float32: whitened form)."""
        return self._prediction_cache(inputs.dtype).sample(inputs, noise)

    def _prediction_cache(self, dtype: torch.dtype) -> _PredictionCache:
        """The cache for predictions in ``dtype``: the GP's own (factorised on first use) or
        one cast from it (kernel copied into ``dtype``, Γ factorised in the GP's dtype)."""
        if self.train_inputs.dtype not in self._caches:  # set and cleared with self._factor
            self.precompute()
        assert self._factor is not None
        if dtype not in self._caches:
            with torch.no_grad():
                kernel = self._kernel_in(dtype)
                self._caches[dtype] = self._cache_from(self._factor, kernel, dtype)
        return self._caches[dtype]

    @torch.no_grad()
    def predicts_in(self, dtype: torch.dtype) -> bool:
        """Whether predictions in ``dtype`` are finite: the kernel's hyper-parameters, cast,
        stay in its range and its covariances at the training inputs come out finite. A
        float64 fit can leave a length-scale at 1e-46 (an irrelevant term: its variance
        1e-101), whose inverse overflows float32 (measured on a UR5 DF model)."""
        cache = self._prediction_cache(dtype)
        cross, prior = cache.kernel(self.train_inputs.to(dtype))
        tensors = [
            cross,
            prior,
            *(t for t in (cache.factor, cache.whitened_targets) if t is not None),
        ]
        return all(bool(torch.isfinite(t).all()) for t in tensors)

    def _kernel_in(self, dtype: torch.dtype) -> Kernel:
        """A copy of the kernel with its hyper-parameters in ``dtype`` (the basis functions
        of a physically-inspired kernel, which belong to the model, are shared)."""
        shared = {id(m.shape): m.shape for m in self.kernel.modules() if isinstance(m, Kernel)}
        twin = copy.deepcopy(self.kernel, memo=shared)
        return twin.to(dtype).requires_grad_(False)

    def hyperparameters(self) -> dict[str, list[float]]:
        """Constrained hyper-parameter values by name, for logs."""
        values = {"noise_std": self.noise_variance.sqrt().tolist()}
        for prefix, module in self.kernel.named_modules():
            if isinstance(module, Kernel):
                for name, value in module.constrained_hyperparameters().items():
                    values[f"{prefix}.{name}" if prefix else name] = value.tolist()
        return values
