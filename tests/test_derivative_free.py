"""Derivative-free model structure: inputs written out by hand, histories, closed loop."""

from __future__ import annotations

from math import cos, sin

import numpy as np
import pytest
import torch

from mcpilco.errors import ConfigError
from mcpilco.estimators import FullStateMeasurement, KalmanEstimator
from mcpilco.models import DerivativeFree
from mcpilco.systems import CartPole

READINGS = np.array([[1.0, 0.5], [1.5, 0.7], [2.5, 0.6], [3.0, 1.0]])  # (p, θ) at t = 0..3
ACTIONS = np.array([[10.0], [20.0], [30.0]])


def make(
    inputs: str = "differences", m_q: int = 2, m_u: int = 1, units: str = "per_step"
) -> DerivativeFree:
    system = CartPole(measured_indices=[0, 2])
    return DerivativeFree(
        system,
        None,
        None,
        None,
        m_q=m_q,
        m_u=m_u,
        inputs=inputs,
        difference_units=units,  # type: ignore[arg-type]
    )


def test_difference_inputs_by_hand() -> None:
    inputs, targets = make().dataset([READINGS], [ACTIONS])
    expected = [
        # p, sin θ, cos θ | Δq_{t-1} (p, θ) | Δq_{t-2} (p, θ) | u_t, u_{t-1}
        [1.0, sin(0.5), cos(0.5), 0.0, 0.0, 0.0, 0.0, 10.0, 0.0],
        [1.5, sin(0.7), cos(0.7), 0.5, 0.2, 0.0, 0.0, 20.0, 10.0],
        [2.5, sin(0.6), cos(0.6), 1.0, -0.1, 0.5, 0.2, 30.0, 20.0],
    ]
    np.testing.assert_allclose(inputs.numpy(), expected, atol=1e-12)
    np.testing.assert_allclose(targets.numpy(), [[0.5, 0.2], [1.0, -0.1], [0.5, 0.4]], atol=1e-12)


def test_differences_per_second_are_divided_by_the_sampling_time() -> None:
    inputs, targets = make(units="per_second").dataset([READINGS], [ACTIONS])
    rate = 1.0 / 0.05  # CartPole's default dt is 0.05 s
    expected = [
        [1.0, sin(0.5), cos(0.5), 0.0, 0.0, 0.0, 0.0, 10.0, 0.0],
        [1.5, sin(0.7), cos(0.7), 0.5 * rate, 0.2 * rate, 0.0, 0.0, 20.0, 10.0],
        [2.5, sin(0.6), cos(0.6), 1.0 * rate, -0.1 * rate, 0.5 * rate, 0.2 * rate, 30.0, 20.0],
    ]
    np.testing.assert_allclose(inputs.numpy(), expected, atol=1e-12)
    np.testing.assert_allclose(targets.numpy(), [[0.5, 0.2], [1.0, -0.1], [0.5, 0.4]], atol=1e-12)


def test_semi_parametric_basis_reads_the_same_velocities_in_either_unit() -> None:
    """The SP basis is built from [q_t, (q_t − q_{t−1}) / dt], whatever the feature units."""
    per_step, per_second = make(), make(units="per_second")
    bases = [m.output_basis(m.dataset([READINGS], [ACTIONS])[0]) for m in (per_step, per_second)]
    torch.testing.assert_close(bases[0], bases[1])
    np.testing.assert_allclose(bases[1][:, 2, 0].numpy(), [1.0 / 0.05, -0.1 / 0.05])


def test_naive_inputs_by_hand() -> None:
    inputs, _ = make("naive", m_q=1, m_u=0).dataset([READINGS], [ACTIONS])
    expected = [
        [1.0, sin(0.5), cos(0.5), 1.0, sin(0.5), cos(0.5), 10.0],
        [1.5, sin(0.7), cos(0.7), 1.0, sin(0.5), cos(0.5), 20.0],
        [2.5, sin(0.6), cos(0.6), 1.5, sin(0.7), cos(0.7), 30.0],
    ]
    np.testing.assert_allclose(inputs.numpy(), expected, atol=1e-12)


@pytest.mark.parametrize("inputs", ["differences", "naive"])
def test_closed_loop_history_rebuilds_the_training_inputs(inputs: str) -> None:
    """Readings fed one by one (as on the system) give the same GP inputs as the data set,
    and the model's transition with the recorded Δq reproduces the next history."""
    model = make(inputs)
    expected, targets = model.dataset([READINGS], [ACTIONS])
    readings = torch.as_tensor(READINGS)
    actions = torch.as_tensor(ACTIONS)
    state, previous_action = None, None
    for t in range(3):
        state = model.closed_loop_state(state, readings[t : t + 1], previous_action)
        np.testing.assert_allclose(
            model.gp_inputs(state, actions[t : t + 1])[0].numpy(), expected[t].numpy()
        )
        following = model.transition(state, actions[t : t + 1], targets[t : t + 1].T)
        rebuilt = model.closed_loop_state(state, readings[t + 1 : t + 2], actions[t : t + 1])
        torch.testing.assert_close(following, rebuilt)
        previous_action = actions[t : t + 1]


def test_particles_start_at_rest_and_report_velocities() -> None:
    model = make()
    states = torch.tensor([[1.0, 5.0, 0.5, -3.0]], dtype=torch.float64)
    particles = model.initial_particles(states)
    assert particles.tolist() == [[1.0, 0.5, 1.0, 0.5, 1.0, 0.5, 0.0]]
    np.testing.assert_allclose(model.physical_state(particles).numpy(), [[1.0, 0.0, 0.5, 0.0]])
    moved = model.transition(particles, torch.tensor([[7.0]]), torch.tensor([[0.1], [-0.2]]))
    np.testing.assert_allclose(moved.numpy(), [[1.1, 0.3, 1.0, 0.5, 1.0, 0.5, 7.0]])
    velocity = model.physical_state(moved).numpy()[0, [1, 3]]
    np.testing.assert_allclose(velocity, [0.1 / 0.05, -0.2 / 0.05])


def test_inconsistent_derivative_free_configs_fail_with_the_key() -> None:
    model = make()
    with pytest.raises(ConfigError, match="estimator=none"):
        model.check_estimator(KalmanEstimator(model.system))
    model.check_estimator(FullStateMeasurement(model.system))  # raw readings: fine
    with pytest.raises(ConfigError, match="measured_indices"):
        DerivativeFree(CartPole(measured_indices=[0]), None, None, None)  # type: ignore[arg-type]
    with pytest.raises(ConfigError, match="model.m_q"):
        make(m_q=0)
    with pytest.raises(ConfigError, match="model.inputs"):
        make("velocities")
    with pytest.raises(ConfigError, match="model.difference_units"):
        make(units="per_minute")


@pytest.mark.parametrize("inputs", ["differences", "naive"])
def test_policy_angle_columns_hold_sin_and_cos_of_the_angle(inputs: str) -> None:
    model = make(inputs)
    particles = model.initial_particles(torch.tensor([[0.3, 0.0, 1.1, 0.0]], dtype=torch.float64))
    features = model.policy_inputs(particles)[0]
    assert model.policy_angle_columns  # one pair per copy of θ in the input
    for sin_column, cos_column in model.policy_angle_columns:
        assert features[sin_column].item() == pytest.approx(sin(1.1))
        assert features[cos_column].item() == pytest.approx(cos(1.1))


def test_known_coordinates_move_by_the_command_and_get_no_gp() -> None:
    """Ball-and-plate DF (§4.4.2): the motors turn by u exactly; GPs only for the ball."""
    from mcpilco.systems import BallAndPlate

    system = BallAndPlate(measured_indices=[0, 1, 4, 5])
    model = DerivativeFree(system, None, None, None, m_q=2, m_u=1, known_coordinates=True)
    assert model.output_names == ["d_q0", "d_q1"]
    readings = np.array(
        [[0.01, 0.02, 0.0, 0.0], [0.015, 0.02, 0.01, -0.02], [0.02, 0.03, 0.03, -0.03]]
    )
    actions = np.array([[0.01, -0.02], [0.02, -0.01]])
    _, targets = model.dataset([readings], [actions])
    np.testing.assert_allclose(targets.numpy(), [[0.005, 0.0], [0.005, 0.01]], atol=1e-12)
    particles = torch.tensor([[0.1, 0.2, 0.3, 0.4, 0.09, 0.19, 0.28, 0.41, 0.08, 0.18, 0.27,
                               0.42, 0.5, 0.6]], dtype=torch.float64)  # fmt: skip
    u = torch.tensor([[0.05, -0.07]], dtype=torch.float64)
    deltas = torch.tensor([[0.01], [-0.02]], dtype=torch.float64)  # [G=2, M=1]
    following = model.transition(particles, u, deltas)
    np.testing.assert_allclose(following[0, :4].numpy(), [0.11, 0.18, 0.35, 0.33], atol=1e-12)
    np.testing.assert_allclose(following[0, 4:12].numpy(), particles[0, :8].numpy())  # shifted
    np.testing.assert_allclose(following[0, 12:].numpy(), [0.05, -0.07])  # u_{t-1} := u_t
