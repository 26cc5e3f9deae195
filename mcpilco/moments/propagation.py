"""PILCO's long-term prediction: a Gaussian state pushed through policy and GP model by
moment matching (Deisenroth & Rasmussen 2011, §2.2–2.3)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import torch

from mcpilco.models.base import ModelStructure
from mcpilco.moments.gaussian import Gaussian, JointGaussian, selection
from mcpilco.moments.rbf import rbf_moments


class MomentPolicy(Protocol):
    """A policy with exact action moments at a Gaussian input (the sine-squashed RBF
    network; a linear policy)."""

    def gaussian_moments(
        self, mean: torch.Tensor, cov: torch.Tensor
    ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        """Mean ``[d_u]``, covariance ``[d_u, d_u]``, factor ``[d_in, d_u]`` (Cov(in, u) =
        cov · factor) for the input N(mean ``[d_in]``, cov)."""
        ...


class ExpectedCost(Protocol):
    """A cost with a closed-form expectation under a Gaussian state."""

    def expected_gaussian(self, mean: torch.Tensor, cov: torch.Tensor) -> torch.Tensor:
        """E c(x), x ~ N(mean ``[d_x]``, cov ``[d_x, d_x]``) (0-dim)."""
        ...


@dataclass
class MomentTrajectory:
    """Σ_t E c(x_t) (0-dim, differentiable), E c(x_t) ``[T+1]``, means ``[T+1, d_x]`` and
    covariances ``[T+1, d_x, d_x]`` of the predicted states."""

    total_cost: torch.Tensor
    step_costs: torch.Tensor
    means: torch.Tensor
    covariances: torch.Tensor


class MomentMatchingRollout:
    """Propagates N(m_t, S_t) of a full-state model (x_{t+1} = x_t + Δ_t, one SE-kernel GP
    per state component) under a sine-squashed RBF policy, for T steps.

    One step: the joint Gaussian of [x, sin x_A, cos x_A] (exact moments), the policy's
    pre-squash output z (exact moments of the RBF network), u = saturation(z) (exact), the
    GP's Δ at the Gaussian input [x*, u] (exact moments of the GP posterior, PILCO's gp0),
    then x + Δ with its cross-covariances. Every step is differentiable (autograd keeps one
    ``[E(E+1)/2, N, N]`` matrix per step for the backward pass: 7 MB at N = 300, E = 4).

    Args:
        model: a fitted full-state model with an SE kernel (the search checks this).
        policy: reads x* = model.encode(x) and has ``gaussian_moments(mean, cov)`` (the
            ``squash="sine"`` RBF policy; any policy with exact moments, e.g. a linear one).
        cost: a cost with ``expected_gaussian(mean, cov)``.
        initial_mean: ``[d_x]``. initial_cov: ``[d_x, d_x]``.
        horizon: T.
    """

    def __init__(
        self,
        model: ModelStructure,
        policy: MomentPolicy,
        cost: ExpectedCost,
        initial_mean: torch.Tensor,
        initial_cov: torch.Tensor,
        horizon: int,
    ) -> None:
        self.model, self.policy, self.cost = model, policy, cost
        self.initial = Gaussian(initial_mean, initial_cov)
        self.horizon = horizon
        features = model.features
        d_x, n_angles = features.state_dim, len(features.angle_indices)
        self.state_dim = d_x
        # joint [x, sin x_A, cos x_A]: rows of x* = [others, sin, cos]
        self.encoded_rows = features.other_indices + [d_x + k for k in range(2 * n_angles)]
        self.trig_size = d_x + 2 * n_angles

    def __call__(self) -> MomentTrajectory:
        mean, cov = self.initial.mean, self.initial.cov
        gp = self.model.gp
        inverse_gram, alpha = gp.posterior_weights()
        kernel = gp.kernel
        gp_terms = (
            gp.train_inputs,
            alpha,
            2.0 * torch.exp(-2.0 * kernel.log_lengthscale.detach()),
            torch.exp(kernel.log_variance.detach()),
            inverse_gram,
        )
        means, covariances = [mean], [cov]
        costs = [self.cost.expected_gaussian(mean, cov)]
        for _ in range(self.horizon):
            mean, cov = self.step(mean, cov, *gp_terms)
            means.append(mean)
            covariances.append(cov)
            costs.append(self.cost.expected_gaussian(mean, cov))
        step_costs = torch.stack(costs)
        return MomentTrajectory(
            step_costs.sum(), step_costs, torch.stack(means), torch.stack(covariances)
        )

    def step(
        self,
        mean: torch.Tensor,
        cov: torch.Tensor,
        train_inputs: torch.Tensor,
        alpha: torch.Tensor,
        inverse_lambda: torch.Tensor,
        signal_variance: torch.Tensor,
        inverse_gram: torch.Tensor,
    ) -> tuple[torch.Tensor, torch.Tensor]:
        """N(m_{t+1}, S_{t+1}) ``[d_x]``, ``[d_x, d_x]`` from N(m_t, S_t)."""
        d_x = self.state_dim
        joint = JointGaussian(mean, cov).with_trig(self.model.features.angle_indices)
        encoded = selection(self.trig_size, self.encoded_rows, mean)
        policy_in = joint.select(encoded)
        u_mean, u_cov, u_factor = self.policy.gaussian_moments(policy_in.mean, policy_in.cov)
        outputs = u_mean.shape[0]
        joint = joint.extend(encoded, u_mean, u_cov, u_factor)  # Cov(joint, u) via the input
        size = self.trig_size
        gp_rows = self.encoded_rows + list(range(size, size + outputs))
        gp_pick = selection(size + outputs, gp_rows, mean)
        gp_in = joint.select(gp_pick)
        delta_mean, delta_cov, delta_factor = rbf_moments(
            train_inputs,
            alpha,
            inverse_lambda,
            signal_variance,
            gp_in.mean,
            gp_in.cov,
            inverse_gram,
        )
        cross = joint.cov[:d_x] @ gp_pick.T @ delta_factor  # Cov(x, Δ) [d_x, d_x]
        next_cov = cov + delta_cov + cross + cross.T
        return mean + delta_mean, 0.5 * (next_cov + next_cov.T)


def initial_covariance(std: torch.Tensor, uniform: bool) -> torch.Tensor:
    """Covariance ``[d_x, d_x]`` of p(x0): diag(std²), or diag(std²/3) when p(x0) is
    uniform on mean ± std (moment matched)."""
    variance = std.square() / (3.0 if uniform else 1.0)
    return torch.diag(variance)


__all__ = ["MomentMatchingRollout", "MomentTrajectory", "initial_covariance"]
