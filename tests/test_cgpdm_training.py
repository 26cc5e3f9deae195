"""The trainer the runner uses (``CGPDMTraining``) against independent references: the
loss it reports and the point it keeps against the dense numpy formula of eq. 6.11 and its
finite differences, eq. 6.11 itself against scipy's Gaussian log-density, a controlled
linear system it must recover, and the best point kept when a factorisation fails."""

from __future__ import annotations

import logging

import numpy as np
import pytest
import torch
from scipy.optimize import minimize
from scipy.stats import multivariate_normal

from mcpilco.errors import NotPositiveDefiniteError
from mcpilco.latent import CGPDM, TrainingData
from mcpilco.latent.training import CGPDMTraining
from tests.test_cgpdm import HIGH, LOW, dense_reference_loss, linear_system_data, tiny_model


def trainable(model: CGPDM) -> list[torch.nn.Parameter]:
    return [p for p in model.parameters() if p.requires_grad]


def dense_gradient(model: CGPDM, step: float = 1e-6) -> np.ndarray:
    """Central differences of the numpy loss over every trainable entry."""
    gradient = []
    with torch.no_grad():
        for parameter in trainable(model):
            flat = parameter.data.view(-1)
            for index in range(flat.numel()):
                original = flat[index].item()
                flat[index] = original + step
                up = dense_reference_loss(model)
                flat[index] = original - step
                down = dense_reference_loss(model)
                flat[index] = original
                gradient.append((up - down) / (2 * step))
    return np.asarray(gradient)


def test_eq_6_11_is_the_negative_gaussian_log_likelihood_of_the_scaled_outputs() -> None:
    """Scale term 1 (eq. 6.11): output j of the latent map is N(0, w_j⁻² K_y) (scipy)."""
    model = tiny_model()
    with torch.no_grad():
        latent, _ = model.loss_terms()
        k_y = model.latent_kernel(model.latent_states, model.latent_states)[0].numpy()
    k_y += (np.exp(2 * model.log_latent_noise.item()) + model.min_noise_variance) * np.eye(len(k_y))
    scales = np.exp(model.log_latent_scale.detach().numpy())
    y = model.centred.numpy()
    log_density = sum(
        multivariate_normal(np.zeros(len(y)), k_y / w**2).logpdf(y[:, j])
        for j, w in enumerate(scales)
    )
    constant = 0.5 * y.size * np.log(2 * np.pi)
    assert latent.item() == pytest.approx(-log_density - constant, rel=1e-10)


@pytest.mark.parametrize("variant", [HIGH, LOW], ids=["high", "low"])
def test_training_stops_where_scipy_does_on_the_dense_loss(variant: dict) -> None:
    """With the latent states held (free, the GPDM loss has no minimum: on this toy it
    falls from -17.7 to -19.0 over 100 more steps, overfitting them), the hyper-parameter
    problem has one; the trainer must stop at a stationary point of the numpy formula, at
    the loss scipy's L-BFGS-B reaches on that formula from the same start."""
    model = tiny_model(**variant)
    model.latent_states.requires_grad_(False)
    parameters = trainable(model)
    start_point = torch.cat([p.detach().reshape(-1) for p in parameters]).numpy().copy()
    start_gradient = np.linalg.norm(dense_gradient(model))

    def dense_loss_at(point: np.ndarray) -> float:
        with torch.no_grad():
            offset = 0
            for parameter in parameters:
                size = parameter.numel()
                parameter.copy_(torch.as_tensor(point[offset : offset + size]).view_as(parameter))
                offset += size
        return dense_reference_loss(model)

    reference = minimize(dense_loss_at, start_point, method="L-BFGS-B", options={"maxiter": 2000})
    dense_loss_at(start_point)
    trace = CGPDMTraining(steps=20, iterations_per_step=20, learning_rate=1.0)(model)
    # the loss it reports is the numpy formula's value at the parameters it kept
    assert trace[-1] == pytest.approx(dense_reference_loss(model), rel=1e-9, abs=1e-9)
    assert trace[-1] == pytest.approx(reference.fun, abs=1e-4)
    assert np.linalg.norm(dense_gradient(model)) < 1e-3 * start_gradient


def test_the_default_schedule_recovers_a_controlled_linear_system() -> None:
    """Held-out sequences of a 3-state system seen through a 30-D linear map."""
    observations, controls = linear_system_data(8, 40, seed=0)
    test_observations, test_controls = linear_system_data(4, 40, seed=1)
    still = (test_observations[:, :1] - test_observations).norm(dim=-1).mean().item()
    for variant, bound in ((HIGH, 0.2), (LOW, 0.5)):
        model = CGPDM(**variant, latent_dim=3)  # type: ignore[arg-type]
        model.set_data(TrainingData(observations, controls))
        CGPDMTraining()(model)
        _, predicted = model.predict(test_controls)
        error = (predicted - test_observations).norm(dim=-1).mean().item()
        assert error < bound * still, (variant, error, still)


def test_a_failed_factorisation_keeps_the_best_point_evaluated(
    monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    model = tiny_model()
    seen: list[tuple[float, list[torch.Tensor]]] = []
    loss_of = CGPDM.negative_log_marginal_likelihood

    def failing_after_12(self: CGPDM) -> torch.Tensor:
        if len(seen) == 12:
            raise NotPositiveDefiniteError("K not positive definite (test)")
        loss = loss_of(self)
        seen.append((loss.item(), [p.detach().clone() for p in trainable(self)]))
        return loss

    monkeypatch.setattr(CGPDM, "negative_log_marginal_likelihood", failing_after_12)
    with caplog.at_level(logging.WARNING):
        trace = CGPDMTraining(steps=5)(model)
    best_loss, best_parameters = min(seen, key=lambda item: item[0])
    assert "stopped early" in caplog.text and len(trace) < 5
    for kept, best in zip(trainable(model), best_parameters, strict=True):
        assert torch.equal(kept.detach(), best)
    assert dense_reference_loss(model) == pytest.approx(best_loss, rel=1e-10)
