"""UR5 tracking task: the circle reference by IK, the PD exploration, the error metrics."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from mcpilco.costs import TrackingCost
from mcpilco.errors import ConfigError
from mcpilco.systems.ur5 import (
    UR5,
    CircleReference,
    PDExploration,
    flange_position,
    position_jacobian,
)
from mcpilco.trajectory import Trajectory


@pytest.fixture(scope="module")
def ur5() -> UR5:
    return UR5()


def test_reference_joints_put_the_flange_on_the_circle(ur5: UR5) -> None:
    reference = ur5.reference
    assert reference.positions.shape == (ur5.num_steps + 1, 6)
    reached = np.array([flange_position(q) for q in reference.positions])
    np.testing.assert_allclose(reached, reference.points, atol=1e-8)
    centre = np.array([-0.5, -0.1, 0.3])
    np.testing.assert_allclose(reached[:, 2], 0.3, atol=1e-8)  # a horizontal circle
    np.testing.assert_allclose(np.linalg.norm(reached - centre, axis=-1), 0.1, atol=1e-8)
    assert np.abs(np.diff(reference.positions, axis=0)).max() < 0.05  # no IK branch jumps


def test_reference_velocities_move_the_flange_along_the_circle(ur5: UR5) -> None:
    """J(q_ref) q̇_ref equals the circle's analytic velocity 2πr/T (−sin, cos, 0)."""
    reference = ur5.reference
    angles = 2 * np.pi * np.arange(ur5.num_steps + 1) * ur5.dt / ur5.trial_duration
    speed = 2 * np.pi * 0.1 / ur5.trial_duration
    expected = speed * np.stack([-np.sin(angles), np.cos(angles), 0 * angles], axis=-1)
    flange = np.array(
        [
            position_jacobian(q) @ v
            for q, v in zip(reference.positions, reference.velocities, strict=True)
        ]
    )
    np.testing.assert_allclose(flange, expected, atol=1e-3 * speed)


def test_perfect_tracking_has_zero_error_and_succeeds(ur5: UR5) -> None:
    states = ur5.reference.states
    actions = np.zeros((ur5.num_steps, 6))
    metrics = ur5.evaluate(Trajectory(states, states, actions, ur5.dt))
    assert metrics["mean_error_mm"] < 1e-5 and metrics["max_error_mm"] < 1e-5
    assert metrics["success"]
    shifted = states.copy()
    shifted[:, 0] += 0.01  # base joint off by 10 mrad: the flange ~5 mm off the circle
    metrics = ur5.evaluate(Trajectory(shifted, shifted, actions, ur5.dt))
    radius = np.linalg.norm(ur5.reference.points[:, :2], axis=-1)  # from the base axis
    np.testing.assert_allclose(metrics["mean_error_mm"], 10 * radius.mean(), rtol=1e-3)
    assert not metrics["success"]


def test_compensated_arm_at_rest_stays_at_rest(ur5: UR5) -> None:
    state = ur5.reference.states[0].copy()
    state[6:] = 0.0
    after = state
    for _ in range(25):
        after = ur5.step(after, np.zeros(6))
    np.testing.assert_allclose(after, state, atol=1e-12)


def test_poorly_tuned_pd_explores_far_from_the_circle_and_gains_help(ur5: UR5) -> None:
    rng = np.random.default_rng(0)
    errors = {}
    for gains in ((1.0, 0.1), (20.0, 2.0)):
        controller = PDExploration(ur5.u_max, 6, rng, ur5, *gains)
        trajectory = ur5.rollout(controller, ur5.sample_initial_state(rng), ur5.num_steps, rng)
        assert np.all(np.abs(trajectory.actions) <= ur5.u_max)
        errors[gains] = ur5.evaluate(trajectory)["mean_error_mm"]
    assert errors[1.0, 0.1] > 50.0  # the thesis's exploration: 141 mm mean
    assert errors[20.0, 2.0] < errors[1.0, 0.1]


def test_circle_out_of_reach_is_a_config_error() -> None:
    with pytest.raises(ConfigError, match="out of the UR5's reach"):
        CircleReference((3.0, 0.0, 0.3), 0.1, duration=1.0, dt=0.1)


def test_tracking_cost_against_its_formula(ur5: UR5) -> None:
    cost = TrackingCost(ur5, position_scale=0.5, velocity_scale=1.0)
    reference = torch.as_tensor(ur5.reference.states)  # [T+1, 12]
    assert float(cost(reference).abs().max()) < 1e-15
    offset = torch.zeros(12, dtype=torch.float64)
    offset[0], offset[1], offset[6] = 0.3, 0.4, 2.0  # |e| = 0.5 rad, |ė| = 2 rad/s
    particles = (reference + offset)[:, None, :].expand(-1, 3, -1)  # [T+1, M=3, 12]
    expected = 1 - np.exp(-((0.5 / 0.5) ** 2) - (2.0 / 1.0) ** 2)
    np.testing.assert_allclose(cost(particles).numpy(), expected, rtol=1e-12)
    np.testing.assert_allclose(cost(particles[:10]).numpy(), expected, rtol=1e-12)  # T' < T


def test_non_tracking_systems_refuse_tracking_pieces() -> None:
    from mcpilco.systems import CartPole

    with pytest.raises(ConfigError, match="tracking"):
        TrackingCost(CartPole())
    with pytest.raises(ConfigError, match="tracking"):
        PDExploration(1.0, 1, np.random.default_rng(0), CartPole())


def test_policy_reads_the_tracking_errors(ur5: UR5) -> None:
    """The UR5 policy input is [q̇, sin q, cos q] and then x_ref(t) − x."""
    from mcpilco.models.speed_integration import SpeedIntegration

    model = SpeedIntegration(ur5, kernel=None, gp=None, fit=None)  # type: ignore[arg-type]
    assert model.policy_input_dim == 18 and model.policy_input_size == 30
    states = torch.as_tensor(ur5.reference.states[[5, 5]]) + 0.01
    inputs = model.with_tracking_errors(model.policy_inputs(states), states, 5)
    assert inputs.shape == (2, 30)
    torch.testing.assert_close(inputs[:, 18:], torch.full((2, 12), -0.01, dtype=torch.float64))
    torch.testing.assert_close(inputs[:, :18], model.policy_inputs(states))


def test_geared_damped_arm_is_held_by_its_gravity_torques_over_the_gear() -> None:
    """The config's plant (gear 101, heavy damping, armature, gravity on): the control
    u = g(q)/gear, with g(q) from mj_inverse of the bare model at rest, holds the arm still,
    and a constant control u moves a joint at the damping's terminal speed gear·u/D."""
    import mujoco

    from mcpilco.systems.ur5_model import ur5_mjcf

    damping = [65.0, 65.0, 65.0, 45.0, 45.0, 45.0]
    arm = UR5(
        gear=101.0,
        armature=0.01,
        joint_damping=damping,
        gravity_compensation=False,
        integrator="IMPLICITFAST",
        u_max=1.0,
    )
    state = arm.reference.states[0].copy()
    state[6:] = 0.0
    bare = mujoco.MjModel.from_xml_string(ur5_mjcf())
    data = mujoco.MjData(bare)
    data.qpos[:] = state[:6]
    mujoco.mj_inverse(bare, data)
    hold = data.qfrc_inverse.copy() / 101.0
    assert np.all(np.abs(hold) < 1.0)  # the arm can hold itself within u_max
    after = state
    for _ in range(25):
        after = arm.step(after, hold)
    np.testing.assert_allclose(after, state, atol=1e-9)
    # wrist 3 turning about its own axis (its gravity load does not change): τ = D q̇
    push = hold.copy()
    push[5] += 0.2
    after = state
    for _ in range(50):
        after = arm.step(after, push)
    np.testing.assert_allclose(after[11], 101.0 * 0.2 / 45.0, rtol=1e-3)


def test_bad_ur5_actuation_names_the_key() -> None:
    with pytest.raises(ConfigError, match="system.joint_damping"):
        UR5(joint_damping=[1.0, 2.0])
    with pytest.raises(ConfigError, match="system.gear"):
        UR5(gear=0.0)


def test_positions_only_tracking_cost_against_its_formula(ur5: UR5) -> None:
    """The DF UR5's cost (§4.3): 1 − exp(−‖e‖²), whatever the velocity error."""
    cost = TrackingCost(ur5, position_scale=1.0, velocity_scale=None)
    reference = torch.as_tensor(ur5.reference.states)
    offset = torch.zeros(12, dtype=torch.float64)
    offset[2], offset[5], offset[9] = 0.3, 0.4, 50.0  # ‖e‖ = 0.5 rad, huge velocity error
    np.testing.assert_allclose(cost(reference + offset).numpy(), 1 - np.exp(-0.25), rtol=1e-12)


def test_pd_on_angles_alone_uses_backward_differences_and_draws_its_gains() -> None:
    ur5 = UR5(measured_indices=[0, 1, 2, 3, 4, 5])
    rng = np.random.default_rng(3)
    draw = np.random.default_rng(3)
    kp, kd = draw.uniform(0.5, 2.0), draw.uniform(0.01, 0.2)  # the same stream, in order
    pd = PDExploration(100.0, 6, rng, ur5, kp_range=[0.5, 2.0], kd_range=[0.01, 0.2])
    np.testing.assert_allclose([pd.kp[0], pd.kd[0]], [kp, kd], rtol=1e-15)
    reference = ur5.reference.states
    angles = [reference[0, :6] + 0.01, reference[1, :6] + 0.03]
    first = pd(angles[0], 0)  # no earlier reading: velocity 0
    np.testing.assert_allclose(first, kp * (reference[0, :6] - angles[0]) + kd * reference[0, 6:])
    second = pd(angles[1], 1)
    velocity = (angles[1] - angles[0]) / ur5.dt
    expected = kp * (reference[1, :6] - angles[1]) + kd * (reference[1, 6:] - velocity)
    np.testing.assert_allclose(second, expected, rtol=1e-12)
    with pytest.raises(ConfigError, match="exploration.kp_range"):
        PDExploration(1.0, 6, rng, ur5, kp_range=[2.0, 0.5])


def test_derivative_free_policy_reads_the_position_errors_from_its_readings() -> None:
    from mcpilco.models import DerivativeFree

    ur5 = UR5(measured_indices=[0, 1, 2, 3, 4, 5])
    model = DerivativeFree(ur5, None, None, None, m_q=2, m_u=1)
    assert model.policy_input_size == model.policy_input_dim + 6  # e_t only, no ė
    readings = torch.tensor(ur5.reference.positions[7])[None].repeat(3, 1) + 0.1
    inputs = torch.zeros(3, model.policy_input_dim, dtype=torch.float64)
    extended = model.with_tracking_errors(inputs, readings, 7)
    np.testing.assert_allclose(extended[:, -6:].numpy(), -0.1, atol=1e-12)
    np.testing.assert_array_equal(extended[:, :-6].numpy(), 0.0)
