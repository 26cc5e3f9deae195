"""CGPDM (thesis §6.2–6.3): loss against a dense-algebra reference, its gradient against
finite differences, PCA against numpy, predictions on a toy controlled linear system."""

from __future__ import annotations

from functools import partial

import numpy as np
import pytest
import torch

from mcpilco.errors import ConfigError
from mcpilco.gp.fit import MarginalLikelihoodFit
from mcpilco.kernels import Constant, Linear, Sum
from mcpilco.kernels import SquaredExponential as SE
from mcpilco.latent import CGPDM, TrainingData, principal_components
from mcpilco.latent.evaluation import point_distance, rigid_baseline, still_baseline

HIGH = {
    "latent_kernel": partial(SE, variance=1.0, train_variance=False),
    "dynamics_kernel": partial(
        Sum,
        terms=[partial(SE, variance=1.0, train_variance=False), partial(Linear), partial(Constant)],
    ),
}
LOW = {
    "latent_kernel": partial(SE, variance=1.0, train_variance=False, isotropic=True),
    "dynamics_kernel": partial(
        Sum, terms=[partial(SE, isotropic=True), partial(Linear, isotropic=True)]
    ),
    "train_latent_scales": False,
    "train_dynamics_scales": False,
}


def linear_system_data(
    num_sequences: int, length: int, seed: int, observation_dim: int = 30
) -> tuple[torch.Tensor, torch.Tensor]:
    """A damped 3-state controlled linear system seen through a fixed random linear map:
    observations ``[P, N, D]``, controls ``[P, N−1, 2]`` (smooth random sinusoids)."""
    a = torch.tensor([[0.95, 0.2, 0.0], [-0.2, 0.95, 0.0], [0.0, 0.0, 0.9]], dtype=torch.float64)
    b = torch.tensor([[0.0, 0.0], [0.3, 0.0], [0.0, 0.2]], dtype=torch.float64)
    c = torch.randn(
        observation_dim, 3, generator=torch.Generator().manual_seed(99), dtype=torch.float64
    )
    rng = torch.Generator().manual_seed(seed)
    frequency = 0.05 + 0.15 * torch.rand(num_sequences, 1, 2, generator=rng, dtype=torch.float64)
    phase = 6.28 * torch.rand(num_sequences, 1, 2, generator=rng, dtype=torch.float64)
    time = torch.arange(length - 1, dtype=torch.float64)[None, :, None]
    controls = torch.cos(6.28 * frequency * time + phase)
    states = [torch.zeros(num_sequences, 3, dtype=torch.float64)]
    for t in range(length - 1):
        states.append(states[-1] @ a.T + controls[:, t] @ b.T)
    latent = torch.stack(states, dim=1)
    return latent @ c.T, controls


def tiny_model(**overrides: object) -> CGPDM:
    observations, controls = linear_system_data(2, 6, seed=1, observation_dim=5)
    model = CGPDM(**{**HIGH, "latent_dim": 2, **overrides})  # type: ignore[arg-type]
    model.set_data(TrainingData(observations, controls))
    with torch.no_grad():  # move every parameter off its initial value
        generator = torch.Generator().manual_seed(3)
        for parameter in model.parameters():
            parameter.add_(
                0.2 * torch.randn(parameter.shape, generator=generator, dtype=parameter.dtype)
            )
    return model


def dense_reference_loss(model: CGPDM) -> float:
    """Eq. 6.11 with numpy: determinants, inverses and traces written out."""
    x = model.latent_states.detach().numpy()
    y = model.centred.numpy()
    with torch.no_grad():
        k_y = model.latent_kernel(model.latent_states, model.latent_states)[0].numpy()
        inputs, targets = model.dynamics_pairs()
        k_x = model.dynamics_kernel(inputs, inputs)[0].numpy()
    k_y = k_y + (np.exp(2 * model.log_latent_noise.item()) + model.min_noise_variance) * np.eye(
        len(x)
    )
    k_x = k_x + (np.exp(2 * model.log_dynamics_noise.item()) + model.min_noise_variance) * np.eye(
        len(k_x)
    )
    w_y = np.diag(np.exp(model.log_latent_scale.detach().numpy()))
    w_x = np.diag(np.exp(model.log_dynamics_scale.detach().numpy()))
    delta = targets.numpy()
    n, dim = y.shape
    c = model.scale_log_det_factor  # 1: eq. 6.11; 2: the authors' library
    latent = (dim / 2 * np.log(np.linalg.det(k_y))
              + 0.5 * np.trace(np.linalg.inv(k_y) @ y @ w_y @ w_y @ y.T)
              - c * n * np.log(np.linalg.det(w_y)))  # fmt: skip
    dynamics = (x.shape[1] / 2 * np.log(np.linalg.det(k_x))
                + 0.5 * np.trace(np.linalg.inv(k_x) @ delta @ w_x @ w_x @ delta.T)
                - c * len(delta) * np.log(np.linalg.det(w_x)))  # fmt: skip
    return float((latent + dynamics) / n)


@pytest.mark.parametrize(
    "variant",
    [HIGH, LOW, {**HIGH, "scale_log_det_factor": 2.0}],
    ids=["high", "low", "high-library-scale-term"],
)
def test_loss_equals_the_dense_formula_of_eq_6_11(variant: dict[str, object]) -> None:
    model = tiny_model(**variant)
    loss = model.negative_log_marginal_likelihood().item()
    assert loss == pytest.approx(dense_reference_loss(model), rel=1e-10, abs=1e-10)
    # multiple sequences: N - P dynamics pairs (§6.2.3), the first state of each sequence
    inputs, targets = model.dynamics_pairs()
    assert targets.shape == (2 * 5, 2) and inputs.shape == (10, 2 + 2)


def test_loss_gradient_matches_central_differences() -> None:
    model = tiny_model()
    parameters = [p for p in model.parameters() if p.requires_grad]
    model.zero_grad()
    model.negative_log_marginal_likelihood().backward()
    checked = 0
    for parameter in parameters:
        flat = parameter.data.view(-1)
        for index in range(0, flat.numel(), max(1, flat.numel() // 4)):
            original = flat[index].item()
            step = 1e-6
            flat[index] = original + step
            up = model.negative_log_marginal_likelihood().item()
            flat[index] = original - step
            down = model.negative_log_marginal_likelihood().item()
            flat[index] = original
            numeric = (up - down) / (2 * step)
            analytic = parameter.grad.view(-1)[index].item()
            assert analytic == pytest.approx(numeric, rel=1e-5, abs=1e-7)
            checked += 1
    assert checked >= 15


def test_pca_initialisation_equals_numpy_pca() -> None:
    data = np.random.default_rng(0).normal(size=(40, 7)) @ np.diag([5, 3, 2, 1, 0.5, 0.2, 0.1])
    centred = data - data.mean(0)
    eigenvalues, eigenvectors = np.linalg.eigh(np.cov(centred.T))
    reference = centred @ eigenvectors[:, ::-1][:, :3]
    ours = principal_components(torch.as_tensor(data), 3).numpy()
    signs = np.sign((ours * reference).sum(0))
    np.testing.assert_allclose(ours, reference * signs, atol=1e-10)
    model = CGPDM(**HIGH, latent_dim=3)  # type: ignore[arg-type]
    observations, controls = linear_system_data(3, 8, seed=0)
    model.set_data(TrainingData(observations, controls))
    np.testing.assert_allclose(
        model.latent_states.detach().numpy(),
        principal_components(observations.reshape(24, -1), 3).numpy(),
        atol=1e-12,
    )


def test_prediction_shapes_determinism_and_constant_coordinates() -> None:
    observations, controls = linear_system_data(4, 12, seed=0)
    observations = torch.cat([observations, torch.full((4, 12, 1), 0.7, dtype=torch.float64)], -1)
    model = CGPDM(**HIGH, latent_dim=3)  # type: ignore[arg-type]
    model.set_data(TrainingData(observations, controls))
    MarginalLikelihoodFit(max_iterations=10)(model)
    latent, predicted = model.predict(controls[:2])
    assert latent.shape == (2, 12, 3) and predicted.shape == (2, 12, 31)
    again = model.predict(controls[:2])
    assert torch.equal(latent, again[0]) and torch.equal(predicted, again[1])
    assert torch.allclose(
        predicted[..., -1], torch.tensor(0.7, dtype=torch.float64), atol=1e-14
    )  # by its mean
    _, variance = model.reconstruct(latent)
    assert torch.all(variance[..., -1] == 0) and torch.all(variance[..., :-1] >= 0)


def test_trained_cgpdm_predicts_held_out_controlled_sequences_of_a_linear_system() -> None:
    observations, controls = linear_system_data(8, 40, seed=0)
    test_observations, test_controls = linear_system_data(4, 40, seed=1)
    errors = {}
    for name, variant in (("high", HIGH), ("low", LOW)):
        model = CGPDM(**variant, latent_dim=3)  # type: ignore[arg-type]
        model.set_data(TrainingData(observations, controls))
        MarginalLikelihoodFit(max_iterations=150)(model)
        _, predicted = model.predict(test_controls)
        errors[name] = np.mean((predicted - test_observations).square().sum(-1).sqrt().numpy())
    still = np.mean((test_observations[:, :1] - test_observations).square().sum(-1).sqrt().numpy())
    assert errors["high"] < 0.2 * still, (errors, still)
    assert errors["low"] < 0.5 * still, (errors, still)


def test_bad_latent_dimension_is_refused_before_training() -> None:
    observations, controls = linear_system_data(2, 6, seed=0, observation_dim=4)
    with pytest.raises(ConfigError, match=r"cgpdm.latent_dim=4 must be below .* D=4"):
        CGPDM(**HIGH, latent_dim=4).set_data(TrainingData(observations, controls))  # type: ignore[arg-type]
    with pytest.raises(ConfigError, match=r"cgpdm.latent_dim=0"):
        CGPDM(**HIGH, latent_dim=0)  # type: ignore[arg-type]
    with pytest.raises(ConfigError, match="controls"):
        CGPDM(**HIGH, latent_dim=2).set_data(TrainingData(observations, controls[:, :3]))  # type: ignore[arg-type]


def test_point_distance_and_baselines_on_known_values() -> None:
    true = np.zeros((1, 2, 6))
    predicted = true.copy()
    predicted[0, 1] = [3, 4, 0, 0, 0, 1]  # distances 5 and 1 at t = 1, 0 at t = 0
    assert point_distance(true, predicted) == pytest.approx([(0 + (5 + 1) / 2) / 2])
    moving = np.arange(12, dtype=float).reshape(1, 2, 6)
    assert np.array_equal(still_baseline(moving)[0, 1], moving[0, 0])
    controls = np.array([[[1.0, 2.0, 3.0, 3.0, 2.0, 1.0]]])  # two grips, mean move (2, 2, 2)
    np.testing.assert_allclose(rigid_baseline(moving, controls)[0, 1], moving[0, 0] + 2.0)
