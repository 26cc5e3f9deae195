"""Furuta pendulum: physics checks, the thesis's cost (eq. 3.2) and the config."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from hydra import compose, initialize_config_dir
from scipy.integrate import solve_ivp
from scipy.linalg import solve_discrete_are

from mcpilco.build import build
from mcpilco.systems import FurutaPendulum
from mcpilco.systems.furuta import furuta_cost
from mcpilco.trajectory import Trajectory
from tests.test_config import CONFIG_DIR


def frictionless(**kwargs: float) -> FurutaPendulum:
    """No damping and no back-emf: zero volts means zero torque."""
    return FurutaPendulum(arm_damping=0.0, pendulum_damping=0.0, back_emf_constant=0.0, **kwargs)


def test_energy_is_conserved_without_friction_and_input() -> None:
    system = frictionless()
    state = np.array([0.3, 4.0, 2.0, -6.0])
    energy = system.energy(state)
    for _ in range(60):
        state = system.step(state, np.zeros(1))
        assert system.energy(state) == pytest.approx(energy, abs=1e-9)


def test_damping_dissipates_and_voltage_does_work() -> None:
    system = FurutaPendulum()
    state = np.array([0.0, 5.0, 1.0, 3.0])
    assert system.energy(system.step(state, np.zeros(1))) < system.energy(state)
    rest = np.zeros(4)
    assert system.energy(system.step(rest, np.array([5.0]))) > system.energy(rest)


def test_pendulum_on_a_locked_arm_swings_as_a_compound_pendulum() -> None:
    """With an immovable arm, small oscillations have ω² = m g (L/2) / (m L²/3) = 3g/(2L)."""
    system = frictionless(rotor_inertia=1e6)
    solution = solve_ivp(
        lambda _t, x: system.derivatives(x, np.zeros(1)),
        (0.0, 3.0),
        np.array([0.0, 0.0, 0.02, 0.0]),
        method="DOP853",
        rtol=1e-10,
        atol=1e-12,
        dense_output=True,
    )
    times = np.linspace(0.0, 3.0, 30001)
    angle = solution.sol(times)[2]
    crossings = times[1:][np.diff(np.sign(angle)) != 0]
    period = 2 * np.mean(np.diff(crossings))
    expected = 2 * np.pi * np.sqrt(2 * system.pendulum_length / (3 * system.gravity))
    assert period == pytest.approx(expected, rel=1e-3)


def test_cost_at_known_states() -> None:
    upright = np.array([0.0, 0.0, np.pi, 0.0])
    assert furuta_cost(upright) == pytest.approx(0.0, abs=1e-9)
    at_barrier = np.array([0.75 * np.pi, 0.0, -np.pi, 0.0])
    expected = 1 - np.exp(-((0.75 * np.pi / 2) ** 2)) + 0.5  # the upper σ is at its midpoint
    assert furuta_cost(at_barrier) == pytest.approx(expected, abs=1e-9)
    hanging = np.zeros(4)
    assert furuta_cost(hanging) == pytest.approx(1 - np.exp(-((np.pi / 2) ** 2)), abs=1e-9)


def test_config_cost_equals_eq_3_2_and_sp_model_builds() -> None:
    with initialize_config_dir(version_base="1.3", config_dir=str(CONFIG_DIR)):
        cfg = compose(
            "train",
            overrides=[
                "system=furuta",
                "cost=furuta_swingup",
                "kernel=sp",
                "estimator=difference",
                "system.measured_indices=[0,2]",
                "system.quantization=0.0015339807878856412",
            ],
        )
    c = build(cfg).components
    states = np.random.default_rng(0).uniform(-4, 4, size=(500, 4))
    torch_cost = c.cost(torch.as_tensor(states)).numpy()
    np.testing.assert_allclose(torch_cost, furuta_cost(states), atol=1e-12)
    assert c.system.sensors.quantised and c.system.num_steps == 90
    rng = np.random.default_rng(1)
    trajectory = c.system.rollout(c.exploration(rng=rng), np.zeros(4), 30, rng)
    readings = trajectory.measurements
    np.testing.assert_allclose(
        readings / (2 * np.pi / 4096), np.round(readings / (2 * np.pi / 4096))
    )
    c.model.fit([c.estimator.offline(readings, c.system.dt)], [trajectory.actions])
    assert c.model.gp is not None and c.model.gp.train_inputs.shape == (30, 7)


def pumping_voltage(
    system: FurutaPendulum,
    state: np.ndarray,
    energy_gain: float,
    arm_gain: float,
    arm_damping: float,
) -> float:
    """Energy pumping with arm centring (V, unclipped):
    energy_gain (E_up − E_v)(−sign(θ̇v cos θv)) − arm_gain θh − arm_damping θ̇h, with E_v the
    pendulum's energy above hanging and E_up its value upright."""
    mass, half_length = system.pendulum_mass, system.pendulum_length / 2
    upright_energy = 2 * mass * system.gravity * half_length
    potential = mass * system.gravity * half_length * (1 - np.cos(state[2]))
    energy = 0.5 * system.pendulum_inertia * state[3] ** 2 + potential
    pumping = energy_gain * (upright_energy - energy)
    pumping *= -np.sign(state[3] * np.cos(state[2]) + 1e-12)
    return float(pumping - arm_gain * state[0] - arm_damping * state[1])


def energy_pumping_peak(system: FurutaPendulum, steps: int) -> tuple[float, int | None]:
    """Full-voltage energy pumping (u = −u_max sign(θ̇v cos θv) while the pendulum's energy is
    below the upright value, an arm-centring term otherwise) from θv = 0.1 rad, held per step
    as the learner's actions are. Returns the largest |θv| reached and the first step within
    0.3 rad of upright (None if never)."""
    state, peak, first_up = np.array([0.0, 0.0, 0.1, 0.0]), 0.0, None
    for step in range(steps):
        voltage = np.clip(
            pumping_voltage(system, state, 2e3, 2.0, 0.1), -system.u_max, system.u_max
        )
        state = system.step(state, np.array([voltage]))
        peak = max(peak, abs(state[2]))
        if first_up is None and abs(abs(state[2]) - np.pi) < 0.3:
            first_up = step
    return peak, first_up


def test_default_rig_can_swing_up_within_the_first_half_of_a_trial() -> None:
    """The task must be physically solvable: plain energy pumping at ≤ 10 V brings the
    pendulum near upright in under 1.5 s (45 steps) of the 3 s trial. With the course
    material's damping (1.5e-3, 5e-4) the same controller, run for 10 s, stays below 1.8 rad."""
    peak, first_up = energy_pumping_peak(FurutaPendulum(), steps=45)
    assert first_up is not None and peak > 2.8
    heavy_peak, heavy_up = energy_pumping_peak(
        FurutaPendulum(arm_damping=1.5e-3, pendulum_damping=5e-4), steps=300
    )
    assert heavy_up is None and heavy_peak < 1.8


def swing_up_and_balance(system: FurutaPendulum, x0: np.ndarray) -> np.ndarray:
    """A hand-made controller for the rig, independent of the learner: energy pumping with
    arm centring, u = 400 (E_up − E_v) · (−sign(θ̇v cos θv)) − 8 θh − 0.2 θ̇h, until the
    pendulum is within 0.3 rad of upright, then a discrete LQR (Q = diag(5, 0.1, 50, 0.5),
    R = 1) on the 30 Hz linearisation about upright. Returns the states ``[91, 4]``."""
    upright = np.array([0.0, 0.0, np.pi, 0.0])
    step = 1e-6
    columns = [
        (system.step(upright + d, np.zeros(1)) - system.step(upright - d, np.zeros(1))) / (2 * step)
        for d in np.eye(4) * step
    ]
    a_matrix = np.stack(columns, axis=1)
    b_matrix = (
        (system.step(upright, np.full(1, step)) - system.step(upright, np.full(1, -step)))
        / (2 * step)
    )[:, None]
    q_matrix, r_matrix = np.diag([5.0, 0.1, 50.0, 0.5]), np.eye(1)
    riccati = solve_discrete_are(a_matrix, b_matrix, q_matrix, r_matrix)
    gain = np.linalg.solve(
        r_matrix + b_matrix.T @ riccati @ b_matrix, b_matrix.T @ riccati @ a_matrix
    )[0]
    states = [x0]
    for _ in range(round(system.trial_duration / system.dt)):
        state = states[-1]
        error = state - upright
        error[2] = np.mod(state[2], 2 * np.pi) - np.pi
        if abs(error[2]) < 0.3:
            voltage = -gain @ error
        else:
            voltage = pumping_voltage(system, state, 400.0, 8.0, 0.2)
        states.append(system.step(state, np.clip([voltage], -system.u_max, system.u_max)))
    return np.array(states)


def test_default_rig_admits_a_swing_up_inside_the_barrier() -> None:
    """The task the learner faces is solvable on the default rig: a hand-made controller
    (energy pumping + LQR catch at 30 Hz, ≤ 10 V) swings the pendulum up in under 1 s,
    keeps the arm inside ±¾π and meets the success test of :meth:`evaluate`, with a
    summed cost (3.2) far below the ≈ 83 of a pendulum left hanging."""
    system = FurutaPendulum()
    states = swing_up_and_balance(system, np.array([0.0, 0.0, 0.05, 0.0]))
    trajectory = Trajectory(
        states=states,
        measurements=states,
        actions=np.zeros((len(states) - 1, 1)),
        dt=system.dt,
    )
    metrics = system.evaluate(trajectory)
    first_up = int(np.argmax(np.abs(np.abs(states[:, 2]) - np.pi) < 0.2))
    assert metrics["success"]
    assert 0 < first_up * system.dt < 1.0
    assert np.abs(states[:, 0]).max() < 0.75 * np.pi
    assert metrics["eval_cost"] < 20.0
