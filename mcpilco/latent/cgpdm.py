"""Controlled Gaussian process dynamical model (thesis §6.2–6.3).

Latent map y = g(x) + n_y and latent dynamics x_{t+1} − x_t = h(x_t, u_t) + n_x, each a
GP whose D (resp. d) outputs share one kernel up to a scale: k_j = w_j⁻² k. The latent
states X of all training sequences are free parameters, initialised by PCA and trained with
the kernels' hyper-parameters by minimising eq. 6.11 (multiple sequences, §6.2.3):

    L_y = D/2 ln|K_y(X)| + ½ tr(K_y⁻¹ Y W_y² Yᵀ) − N ln|W_y|
    L_x = d/2 ln|K_x(X̃)| + ½ tr(K_x⁻¹ Δ W_x² Δᵀ) − (N − P) ln|W_x|

(the negative log-likelihoods of the two GPs whose outputs have std w⁻¹; the authors'
library weights both scale terms twice, −2N ln|W|: ``scale_log_det_factor=2``).

Observations are centred on their training mean (a zero-mean GP on raw positions would
pull every prediction towards the origin), and controls are divided by their training
standard deviation (the cloth's u is ~1 cm per step, far below the unit initial
length-scales of the dynamics kernel, whose gradient then barely reaches them). Coordinates
that never move in the training data (to 1e-9 m) are predicted by that mean and left out of
the latent GP, whose trainable scale would otherwise grow without bound on an all-zero
column.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import torch
from torch import nn

from mcpilco.errors import ConfigError
from mcpilco.extension import ExtensionPoint
from mcpilco.gp.linalg import cholesky_with_jitter
from mcpilco.kernels.base import Kernel, KernelFactory, KernelShape
from mcpilco.latent.pca import principal_components

CONSTANT_TOLERANCE = 1e-9
"""Observation coordinates whose training standard deviation is below this are constant."""


@dataclass(frozen=True)
class TrainingData:
    """P training sequences of equal length N.

    Attributes:
        observations: ``[P, N, D]`` (m for the cloth).
        controls: ``[P, N−1, E]``.
    """

    observations: torch.Tensor
    controls: torch.Tensor


class CGPDM(ExtensionPoint, nn.Module):
    """A CGPDM with latent dimension d on the kernel library.

    Args:
        latent_kernel: factory of k_y (one output, input dimension d).
        dynamics_kernel: factory of k_x (one output, input dimension d + E).
        latent_dim: d.
        latent_noise: initial σ_y (std of n_y in the scaled output).
        dynamics_noise: initial σ_x.
        train_latent_scales: whether w_y are trained (else fixed at their initial value).
        train_dynamics_scales: whether w_x are trained.
        latent_scale: initial w_y.
        dynamics_scale: initial w_x.
        min_noise: numerical floor added to both noise standard deviations' variances.
        center_observations: subtract the training mean from y (the authors' library does
            not: its latent GP models the raw coordinates).
        scale_log_det_factor: c in the scale terms −c N ln|W_y| and −c (N − P) ln|W_x|
            (1: eq. 6.11, the likelihood; 2: the authors' library).
    """

    def __init__(
        self,
        latent_kernel: KernelFactory,
        dynamics_kernel: KernelFactory,
        latent_dim: int = 3,
        latent_noise: float = 1.0,
        dynamics_noise: float = 1.0,
        train_latent_scales: bool = True,
        train_dynamics_scales: bool = True,
        latent_scale: float = 1.0,
        dynamics_scale: float = 1.0,
        min_noise: float = 1e-3,
        center_observations: bool = True,
        scale_log_det_factor: float = 1.0,
    ) -> None:
        super().__init__()
        if not isinstance(latent_dim, int) or latent_dim < 1:
            raise ConfigError(f"cgpdm.latent_dim={latent_dim!r} must be a positive integer")
        for name, value in (
            ("latent_noise", latent_noise),
            ("dynamics_noise", dynamics_noise),
            ("latent_scale", latent_scale),
            ("dynamics_scale", dynamics_scale),
            ("min_noise", min_noise),
            ("scale_log_det_factor", scale_log_det_factor),
        ):
            if not isinstance(value, int | float) or not 0 < value < math.inf:
                raise ConfigError(f"cgpdm.{name}={value!r} must be positive (and finite)")
        for name, flag in (
            ("train_latent_scales", train_latent_scales),
            ("train_dynamics_scales", train_dynamics_scales),
            ("center_observations", center_observations),
        ):
            if not isinstance(flag, bool):
                raise ConfigError(f"cgpdm.{name}={flag!r} must be true or false")
        self.latent_dim = latent_dim
        self._latent_kernel_factory = latent_kernel
        self._dynamics_kernel_factory = dynamics_kernel
        self._init = {
            "latent_noise": float(latent_noise),
            "dynamics_noise": float(dynamics_noise),
            "latent_scale": float(latent_scale),
            "dynamics_scale": float(dynamics_scale),
        }
        self.train_latent_scales = train_latent_scales
        self.train_dynamics_scales = train_dynamics_scales
        self.min_noise_variance = float(min_noise) ** 2
        self.center_observations = bool(center_observations)
        self.scale_log_det_factor = float(scale_log_det_factor)
        self.output_names = "CGPDM"
        self._posterior: _Posterior | None = None

    # ------------------------------------------------------------------ set-up
    def set_data(self, data: TrainingData) -> None:
        """Build every parameter for ``data`` (kernels, scales, noises, PCA latent states)."""
        observations = data.observations.to(torch.float64)
        controls = data.controls.to(torch.float64)
        p, n, dim = observations.shape
        if controls.shape[:2] != (p, n - 1):
            raise ConfigError(
                f"controls {tuple(controls.shape)} do not match observations "
                f"{tuple(observations.shape)} (want [P, N-1, E])"
            )
        self.check_observation_dim(dim)
        flat = observations.reshape(p * n, dim)
        mean = flat.mean(0) if self.center_observations else torch.zeros_like(flat[0])
        self.register_buffer("observation_mean", mean)
        moving = (flat - mean).abs().amax(0) > CONSTANT_TOLERANCE
        if int(moving.sum()) <= self.latent_dim:
            raise ConfigError(
                f"only {int(moving.sum())} observation coordinates vary in the training data; "
                f"need more than cgpdm.latent_dim={self.latent_dim}"
            )
        self.register_buffer("moving", moving)
        self.register_buffer("centred", (flat - self.observation_mean)[:, moving].contiguous())
        control_std = controls.reshape(-1, controls.shape[-1]).std(0)
        control_scale = torch.where(control_std > CONSTANT_TOLERANCE, control_std, 1.0)
        self.register_buffer("control_scale", control_scale)
        self.register_buffer("controls", controls / control_scale)
        self.num_sequences, self.sequence_length = p, n
        control_dim = controls.shape[-1]
        self.latent_kernel: Kernel = self._latent_kernel_factory(
            KernelShape(num_outputs=1, input_dim=self.latent_dim)
        )
        self.dynamics_kernel: Kernel = self._dynamics_kernel_factory(
            KernelShape(num_outputs=1, input_dim=self.latent_dim + control_dim)
        )
        self.latent_states = nn.Parameter(principal_components(self.centred, self.latent_dim))
        active = int(moving.sum())
        init = self._init
        self.log_latent_scale = nn.Parameter(
            torch.full((active,), init["latent_scale"], dtype=torch.float64).log(),
            requires_grad=self.train_latent_scales,
        )
        self.log_dynamics_scale = nn.Parameter(
            torch.full((self.latent_dim,), init["dynamics_scale"], dtype=torch.float64).log(),
            requires_grad=self.train_dynamics_scales,
        )
        self.log_latent_noise = nn.Parameter(torch.tensor(init["latent_noise"]).log().double())
        self.log_dynamics_noise = nn.Parameter(torch.tensor(init["dynamics_noise"]).log().double())
        self.to(observations.device)  # kernels and scales join the data's device
        self._posterior = None

    def check_kernels(self, control_dim: int) -> None:
        """Build both kernels once on their input shapes (with ``control_dim`` controls),
        so that a bad kernel value is refused in one line before any data are made."""
        self._latent_kernel_factory(KernelShape(num_outputs=1, input_dim=self.latent_dim))
        self._dynamics_kernel_factory(
            KernelShape(num_outputs=1, input_dim=self.latent_dim + control_dim)
        )

    def check_observation_dim(self, observation_dim: int) -> None:
        """One-line :class:`ConfigError` unless d < D (before any data are simulated)."""
        if self.latent_dim >= observation_dim:
            raise ConfigError(
                f"cgpdm.latent_dim={self.latent_dim} must be below the observation "
                f"dimension D={observation_dim}"
            )

    @property
    def observation_dim(self) -> int:
        return int(self.moving.numel())

    def sequences(self) -> torch.Tensor:
        """Latent states per sequence ``[P, N, d]``."""
        return self.latent_states.reshape(self.num_sequences, self.sequence_length, -1)

    def dynamics_pairs(self) -> tuple[torch.Tensor, torch.Tensor]:
        """GP inputs X̃ = [x_t, u_t] ``[P(N−1), d+E]`` and targets Δ ``[P(N−1), d]``."""
        x = self.sequences()
        inputs = torch.cat([x[:, :-1], self.controls], dim=-1)
        return inputs.reshape(-1, inputs.shape[-1]), (x[:, 1:] - x[:, :-1]).reshape(-1, x.shape[-1])

    # ------------------------------------------------------------------ loss
    def _noise(self, log_noise: torch.Tensor) -> torch.Tensor:
        return torch.exp(2.0 * log_noise) + self.min_noise_variance

    def _gram(self, kernel: Kernel, inputs: torch.Tensor, log_noise: torch.Tensor) -> torch.Tensor:
        gram = kernel(inputs, inputs)[0]
        return gram + self._noise(log_noise) * torch.eye(
            len(inputs), dtype=gram.dtype, device=gram.device
        )

    def _term(
        self, factor: torch.Tensor, targets: torch.Tensor, log_scale: torch.Tensor
    ) -> torch.Tensor:
        """M/2 ln|K| + ½ tr(K⁻¹ T W² Tᵀ) − c n ln|W| for K = L Lᵀ, T ``[n, M]``."""
        n, outputs = targets.shape
        whitened = torch.linalg.solve_triangular(
            factor, targets * torch.exp(log_scale), upper=False
        )
        log_det = 2.0 * torch.log(torch.diagonal(factor)).sum()
        scale_term = self.scale_log_det_factor * n * log_scale.sum()
        return 0.5 * outputs * log_det + 0.5 * whitened.square().sum() - scale_term

    def _factors(self) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor, torch.Tensor]:
        """Cholesky factors of K_y(X) and K_x(X̃), with the dynamics pairs (X̃, Δ)."""
        latent_factor = cholesky_with_jitter(
            self._gram(self.latent_kernel, self.latent_states, self.log_latent_noise),
            "CGPDM latent map",
        )
        inputs, targets = self.dynamics_pairs()
        dynamics_factor = cholesky_with_jitter(
            self._gram(self.dynamics_kernel, inputs, self.log_dynamics_noise),
            "CGPDM latent dynamics",
        )
        return latent_factor, dynamics_factor, inputs, targets

    def loss_terms(self) -> tuple[torch.Tensor, torch.Tensor]:
        """(L_y, L_x) of eq. 6.11."""
        latent_factor, dynamics_factor, _, targets = self._factors()
        latent = self._term(latent_factor, self.centred, self.log_latent_scale)
        dynamics = self._term(dynamics_factor, targets, self.log_dynamics_scale)
        return latent, dynamics

    def negative_log_marginal_likelihood(self) -> torch.Tensor:
        """(L_y + L_x) / N, N the number of training observations."""
        latent, dynamics = self.loss_terms()
        return (latent + dynamics) / self.latent_states.shape[0]

    # ------------------------------------------------------------------ prediction
    def precompute(self) -> None:
        """Cache K⁻¹ Y and K⁻¹ Δ factors for prediction (after training)."""
        with torch.no_grad():
            latent_factor, dynamics_factor, inputs, targets = self._factors()
            self._posterior = _Posterior(
                latent_inputs=self.latent_states.detach().clone(),
                latent_factor=latent_factor,
                latent_weights=torch.cholesky_solve(self.centred, latent_factor),
                dynamics_inputs=inputs.detach().clone(),
                dynamics_factor=dynamics_factor,
                dynamics_weights=torch.cholesky_solve(targets, dynamics_factor),
            )

    def _posterior_or_fail(self) -> _Posterior:
        if self._posterior is None:
            self.precompute()
        assert self._posterior is not None
        return self._posterior

    def initial_latent_state(self) -> torch.Tensor:
        """Mean of the training sequences' first latent states ``[d]`` (all sequences start
        from the same configuration in the thesis's protocol)."""
        return self.sequences()[:, 0].detach().mean(0)

    @torch.no_grad()
    def predict_latent(self, x0: torch.Tensor, controls: torch.Tensor) -> torch.Tensor:
        """Mean propagation (§6.3.2–6.3.3): x_{t+1} = x_t + E[h(x_t, u_t)].

        Args:
            x0: initial latent states ``[S, d]``.
            controls: ``[S, T−1, E]``.
        Returns:
            latent trajectories ``[S, T, d]``.
        """
        posterior = self._posterior_or_fail()
        like = self.latent_states
        states = [x0.to(like)]
        for t in range(controls.shape[1]):
            control = controls[:, t].to(like) / self.control_scale
            query = torch.cat([states[-1], control], dim=-1)
            cross = self.dynamics_kernel(query, posterior.dynamics_inputs)[0]  # [S, N−P]
            states.append(states[-1] + cross @ posterior.dynamics_weights)
        return torch.stack(states, dim=1)

    @torch.no_grad()
    def reconstruct(self, latent: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """Latent prediction (§6.3.1): mean and variance of y for latent states ``[..., d]``.

        Returns:
            ``(mean [..., D], variance [..., D])``; constant coordinates have variance 0.
        """
        posterior = self._posterior_or_fail()
        flat = latent.reshape(-1, latent.shape[-1]).to(self.latent_states)
        cross = self.latent_kernel(flat, posterior.latent_inputs)[0]  # [M, N]
        mean_moving = cross @ posterior.latent_weights
        solved = torch.cholesky_solve(cross.T, posterior.latent_factor)  # [N, M]
        common = self.latent_kernel.diag(flat)[0] - (cross.T * solved).sum(0)
        scale = torch.exp(-2.0 * self.log_latent_scale.detach())
        mean = self.observation_mean.expand(len(flat), -1).clone()
        mean[:, self.moving] += mean_moving
        variance = torch.zeros_like(mean)
        variance[:, self.moving] = common.clamp_min(0.0)[:, None] * scale
        shape = (*latent.shape[:-1], self.observation_dim)
        return mean.reshape(shape), variance.reshape(shape)

    def predict(self, controls: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """Trajectory prediction (§6.3.3) from the common initial state.

        Args:
            controls: ``[S, T−1, E]``.
        Returns:
            ``(latent [S, T, d], observations [S, T, D])`` (means).
        """
        x0 = self.initial_latent_state().expand(controls.shape[0], -1)
        latent = self.predict_latent(x0, controls)
        return latent, self.reconstruct(latent)[0]


@dataclass(frozen=True)
class _Posterior:
    latent_inputs: torch.Tensor
    latent_factor: torch.Tensor
    latent_weights: torch.Tensor
    dynamics_inputs: torch.Tensor
    dynamics_factor: torch.Tensor
    dynamics_weights: torch.Tensor
