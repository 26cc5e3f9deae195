"""A GP model of the inverse dynamics τ = f(q, q̇, q̈), one GP per joint (thesis §5.1.2),
and the dynamics components estimated from it (eq. 5.7–5.9)."""

from __future__ import annotations

import copy
import time
from dataclasses import dataclass
from typing import Any

import numpy as np
import torch

from mcpilco.control.data import InverseDynamicsData
from mcpilco.errors import ConfigError
from mcpilco.gp.exact import ExactGP
from mcpilco.gp.fit import MarginalLikelihoodFit
from mcpilco.gp.linalg import cholesky_with_jitter
from mcpilco.kernels.base import KernelFactory, KernelShape


@dataclass
class InverseDynamicsFit:
    """What fitting cost: points used for the hyper-parameters and for the posterior,
    −log p(y|X)/N on the fitting subset, seconds for ML-II and for the full factorisation."""

    fit_points: int
    posterior_points: int
    negative_log_likelihood: float
    hyperparameter_seconds: float
    posterior_seconds: float


class GPInverseDynamics:
    """n independent GPs f̂_i(q, q̇, q̈) (posterior means) of the joint torques.

    Inputs [q, q̇, q̈] enter the kernel with q̇ and q̈ divided by their training std (a
    fixed linear map: a polynomial kernel stays polynomial in them) and the torques are
    standardised per joint; predictions are in N m.

    Hyper-parameters are trained by marginal likelihood on ``fit_points`` samples drawn at
    random (all when None), the posterior mean uses every sample.

    Args:
        kernel: kernel factory (a ``kernel=`` config), completed with n outputs, 3n inputs.
        num_joints: n.
        noise_std: initial noise std of the standardised torques.
        fit_points: samples for ML-II (None: all).
        max_iterations: L-BFGS iterations of the fit.
        block_size: rows of the kernel matrix computed at once (memory).
    """

    def __init__(
        self,
        kernel: KernelFactory,
        num_joints: int,
        noise_std: float = 0.1,
        fit_points: int | None = 1000,
        max_iterations: int = 200,
        block_size: int = 500,
    ) -> None:
        if fit_points is not None and fit_points < 10:
            raise ConfigError(f"gp.fit_points={fit_points} must be >= 10 or null")
        self.num_joints = num_joints
        self.gp = ExactGP(
            kernel(KernelShape(num_joints, 3 * num_joints)),
            noise_std=noise_std,
            output_names=[f"tau{j + 1}" for j in range(num_joints)],
        )
        self.fitter = MarginalLikelihoodFit(max_iterations=max_iterations)
        self.fit_points = fit_points
        self.block_size = block_size
        self.input_scale = torch.ones(3 * num_joints, dtype=torch.float64)
        self.target_scale = torch.ones(num_joints, dtype=torch.float64)
        self._prepared = None
        self._alpha: torch.Tensor | None = None  # [G, N, 1]
        self._prediction: tuple[Any, torch.Tensor, torch.dtype] | None = None  # predict_in
        self._step_weights: torch.Tensor | None = None  # α ⊙ F [G, n, N] (components)

    # --------------------------------------------------------------------- fitting
    def _scaled(self, inputs: torch.Tensor) -> torch.Tensor:
        return inputs / self.input_scale

    def _standardised(self, data: InverseDynamicsData) -> tuple[torch.Tensor, torch.Tensor]:
        """Set the input and target scales from ``data``; its scaled inputs and targets."""
        inputs = torch.as_tensor(data.inputs, dtype=torch.float64)
        targets = torch.as_tensor(data.torques, dtype=torch.float64)
        n = self.num_joints
        scale = torch.ones(3 * n, dtype=torch.float64)
        scale[n:] = inputs[:, n:].std(0).clamp_min(1e-9)
        self.input_scale, self.target_scale = scale, targets.std(0).clamp_min(1e-9)
        return self._scaled(inputs), targets / self.target_scale

    def condition(self, data: InverseDynamicsData) -> None:
        """The posterior on ``data`` with the hyper-parameters as they are (no ML-II)."""
        self._set_posterior(*self._standardised(data))

    def fit(self, data: InverseDynamicsData, generator: torch.Generator) -> InverseDynamicsFit:
        """ML-II on a random subset, then the posterior on all of ``data``."""
        x, y = self._standardised(data)
        count = x.shape[0] if self.fit_points is None else min(self.fit_points, x.shape[0])
        subset = torch.randperm(x.shape[0], generator=generator)[:count]
        start = time.perf_counter()
        self.gp.set_data(x[subset], y[subset])
        nll = self.fitter(self.gp)
        hyper_seconds = time.perf_counter() - start
        start = time.perf_counter()
        self._set_posterior(x, y)
        return InverseDynamicsFit(
            count, x.shape[0], nll, hyper_seconds, time.perf_counter() - start
        )

    @torch.no_grad()
    def _set_posterior(self, x: torch.Tensor, y: torch.Tensor) -> None:
        """α = (K + σ² I)⁻¹ y on all samples, the kernel matrix built in row blocks."""
        self.gp.set_data(x, y)
        kernel, size = self.gp.kernel, x.shape[0]
        gram = torch.empty(self.num_joints, size, size, dtype=x.dtype)
        for start in range(0, size, self.block_size):
            gram[:, start : start + self.block_size] = kernel(x[start : start + self.block_size], x)
        gram.diagonal(dim1=-2, dim2=-1).add_(self.gp.noise_variance[:, None])
        factor = cholesky_with_jitter(gram, f"GP outputs {self.gp.output_names}")
        del gram
        self._alpha = torch.cholesky_solve(y.T.unsqueeze(-1), factor)
        self._prepare_prediction()

    def _prepare_prediction(self) -> None:
        """What every prediction reuses: the kernel's training side and, where the kernel
        offers step factors F (SE), the weights α ⊙ F of the unit-acceleration rows."""
        assert self._alpha is not None
        x, n = self.gp.train_inputs, self.num_joints
        self._prepared = self.gp.kernel.prepare_cross(x)
        self._prediction = None
        steps = (1.0 / self.input_scale[2 * n :]).tolist()  # q̈ = 1 rad/s², scaled
        factors = self.gp.kernel.step_factors(x, list(range(2 * n, 3 * n)), steps)
        self._step_weights = None if factors is None else factors * self._alpha.mT

    # ------------------------------------------------------------------ prediction
    @torch.no_grad()
    def predict_in(self, dtype: torch.dtype, tolerance: float = 0.01) -> None:
        """Predict in ``dtype`` from now on (float32: about half the time per call at
        n = 5000 with GIP; α and the hyper-parameters stay as fitted in float64, cast).

        A lower precision is refused (:class:`ConfigError`) where it changes this model's
        predictions: on up to 256 training inputs the RMS difference from float64 must stay
        below ``tolerance`` × each joint's torque std. (Measured: the committed GIP model
        differs by 0.2 %; the SE model, whose α cancels (Σ|α| ≈ 1e5), by 29 %.)"""
        if self._alpha is None:
            raise RuntimeError("GPInverseDynamics.predict_in before fit or load")
        self._prediction = None
        if dtype == torch.float64:
            return
        assert self._prepared is not None
        kernel = copy.deepcopy(self.gp.kernel).to(dtype)
        prepared = kernel.prepare_cross(self.gp.train_inputs.to(dtype))
        alpha = self._alpha.to(dtype)
        sample = self.gp.train_inputs[:256]  # scaled inputs; standardised targets (std 1)
        exact = torch.matmul(self._prepared(sample), self._alpha)[..., 0]  # [G, M]
        lower = torch.matmul(prepared(sample.to(dtype)), alpha)[..., 0].double()
        rms = (exact - lower).square().mean(-1).sqrt()  # [G] in torque stds
        worst = int(rms.argmax())
        if rms[worst] > tolerance:
            raise ConfigError(
                f"{str(dtype).removeprefix('torch.')} prediction changes this model's torques "
                f"by {100 * float(rms[worst]):.1f} % of joint {worst + 1}'s torque std (RMS on "
                f"its training inputs; limit {100 * tolerance:g} %): keep float64"
            )
        self._prediction = (prepared, alpha, dtype)

    def _cross(self, inputs: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """(k(x, X) ``[G, M, N]``, α ``[G, N, 1]``) in the prediction dtype."""
        if self._prepared is None or self._alpha is None:
            raise RuntimeError("GPInverseDynamics used before fit or load")
        scaled = self._scaled(inputs)
        if self._prediction is not None:
            prepared, alpha, dtype = self._prediction
            return prepared(scaled.to(dtype)), alpha
        return self._prepared(scaled), self._alpha

    @torch.no_grad()
    def torques(self, inputs: torch.Tensor) -> torch.Tensor:
        """f̂(q, q̇, q̈) ``[M, n]`` (N m, float64) at inputs ``[M, 3n]`` = [q, q̇, q̈]."""
        cross, alpha = self._cross(inputs)
        return torch.matmul(cross, alpha)[..., 0].T.double() * self.target_scale

    @property
    def affine_in_accelerations(self) -> bool:
        """Whether f̂ is affine in q̈ (the kernel says so): then f̂(q, q̇, a) = B̂(q) a +
        n̂(q, q̇) exactly (thesis §5.4.2)."""
        n = self.num_joints
        return set(range(2 * n, 3 * n)) <= set(self.gp.kernel.affine_columns)

    def components_inputs(self, positions: torch.Tensor, velocities: torch.Tensor) -> torch.Tensor:
        """The n + 2 inputs of one batched call for ĝ, B̂ and n̂ (eq. 5.7–5.9):
        [q, 0, 0], [q, 0, 1_j] for j = 1..n, [q, q̇, 0] — ``[n + 2, 3n]``."""
        n = self.num_joints
        rows = torch.zeros(n + 2, 3 * n, dtype=positions.dtype)
        rows[:, :n] = positions
        rows[1 : n + 1, 2 * n :] = torch.eye(n, dtype=positions.dtype)
        rows[n + 1, n : 2 * n] = velocities
        return rows

    @torch.no_grad()
    def components(
        self, positions: torch.Tensor, velocities: torch.Tensor
    ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        """(B̂(q) ``[n, n]``, n̂(q, q̇) ``[n]``, ĝ(q) ``[n]``): ĝ = f̂(q, 0, 0),
        B̂_ij = f̂_i(q, 0, 1_j) − ĝ_i, n̂ = f̂(q, q̇, 0). With the kernel's step factors
        (SE) the n rows [q, 0, 1_j] are the row [q, 0, 0] weighted by α ⊙ F_j, so one call
        costs two kernel rows instead of n + 2 (exact; tested against the rows)."""
        rows = self.components_inputs(positions, velocities)
        if self._step_weights is None:
            values = self.torques(rows)
        else:
            n = self.num_joints
            cross, alpha = self._cross(rows[[0, n + 1]])  # [G, 2, N]
            weights = self._step_weights.to(cross.dtype)  # [G, n, N]
            steps = torch.matmul(weights, cross[:, 0, :, None])[..., 0]  # [G, n]
            ends = torch.matmul(cross, alpha)[..., 0]  # [G, 2]: gravity, bias
            values = torch.cat([ends[:, :1], steps, ends[:, 1:]], 1).T.double()
            values = values * self.target_scale
        gravity = values[0]
        inertia = (values[1:-1] - gravity).T  # row i: joint torque i, column j: 1_j
        return inertia, values[-1], gravity

    # ------------------------------------------------------------------ persistence
    def state_dict(self) -> dict[str, torch.Tensor]:
        """Tensors only: GP hyper-parameters and data, α, scales."""
        if self._alpha is None:
            raise RuntimeError("GPInverseDynamics.state_dict before fit")
        return {
            **{f"gp.{k}": v for k, v in self.gp.state_dict().items()},
            "alpha": self._alpha,
            "input_scale": self.input_scale,
            "target_scale": self.target_scale,
        }

    def load_state_dict(self, state: dict[str, torch.Tensor]) -> None:
        gp_state = {k.removeprefix("gp."): v for k, v in state.items() if k.startswith("gp.")}
        self.gp.set_data(gp_state["train_inputs"], gp_state["train_targets"])
        self.gp.load_state_dict(gp_state)
        self._alpha = state["alpha"]
        self.input_scale, self.target_scale = state["input_scale"], state["target_scale"]
        self._prepare_prediction()


def nmse_percent(predicted: np.ndarray, measured: np.ndarray) -> np.ndarray:
    """Normalised mean squared error per joint, % (MSE / variance of the measured torque)."""
    return 100 * ((predicted - measured) ** 2).mean(0) / measured.var(0)
