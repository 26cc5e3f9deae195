"""The ``reference`` group (seeded sines, explicit sums of sines, a trajectory file), the
robot's torque limits in tracking, and arms with joints that are not controlled."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from mcpilco.control import (
    PyBulletArm,
    RandomSumOfSines,
    SumOfSines,
    ThesisSines,
    TrajectoryFile,
    TrueModelFL,
    track,
)
from mcpilco.errors import ConfigError

TIMES = np.array([0.0, 0.37, 1.21, 2.5, 4.93])


def finite_differences(reference, t: np.ndarray, h: float = 1e-5):  # type: ignore[no-untyped-def]
    r_plus, rd_plus, _ = reference(t + h)
    r_minus, rd_minus, _ = reference(t - h)
    return (r_plus - r_minus) / (2 * h), (rd_plus - rd_minus) / (2 * h)


def test_thesis_sines_are_the_closed_form_with_their_derivatives() -> None:
    """r_j = o_j + A t sin(2π F_j t), F_j = 0.5 + 1.0 · N(0, 1) from default_rng(seed)."""
    (reference,) = ThesisSines(seeds=[7], offsets=[0.1, -0.2, 0.3]).references(3)
    frequencies = 0.5 + np.random.default_rng(7).standard_normal(3)
    w, t = 2 * np.pi * frequencies, TIMES[:, None]
    r, rd, rdd = reference(TIMES)
    np.testing.assert_allclose(r, [0.1, -0.2, 0.3] + 0.165 * t * np.sin(w * t))
    np.testing.assert_allclose(rd, 0.165 * (np.sin(w * t) + w * t * np.cos(w * t)))
    np.testing.assert_allclose(rdd, 0.165 * (2 * w * np.cos(w * t) - w**2 * t * np.sin(w * t)))
    velocity, acceleration = finite_differences(reference, TIMES)
    np.testing.assert_allclose(rd, velocity, atol=1e-7)
    np.testing.assert_allclose(rdd, acceleration, atol=1e-5)
    assert reference.label == "seed_07" and reference.duration == 5.0


def test_an_explicit_sum_of_sines_with_any_number_of_terms() -> None:
    family = SumOfSines(
        amplitudes=[[0.3, 0.1, 0.05], 0.2],
        frequencies=[[0.2, 0.7, 1.9], 0.5],
        phases=[[0.0, 1.0, -0.5], 2.0],
        offsets=[0.4, -1.0],
        duration=3.0,
    )
    (reference,) = family.references(2)
    r, rd, rdd = reference(TIMES)
    t = TIMES
    a, f, p = np.array([0.3, 0.1, 0.05]), np.array([0.2, 0.7, 1.9]), np.array([0.0, 1.0, -0.5])
    w = 2 * np.pi * f
    np.testing.assert_allclose(r[:, 0], 0.4 + (a * np.sin(np.outer(t, w) + p)).sum(1))
    np.testing.assert_allclose(rd[:, 0], (a * w * np.cos(np.outer(t, w) + p)).sum(1))
    np.testing.assert_allclose(rdd[:, 0], -(a * w**2 * np.sin(np.outer(t, w) + p)).sum(1))
    w1 = 2 * np.pi * 0.5
    np.testing.assert_allclose(r[:, 1], -1.0 + 0.2 * np.sin(w1 * t + 2.0))
    np.testing.assert_allclose(rdd[:, 1], -0.2 * w1**2 * np.sin(w1 * t + 2.0))
    velocity, acceleration = finite_differences(reference, TIMES)
    np.testing.assert_allclose(rd, velocity, atol=1e-7)
    np.testing.assert_allclose(rdd, acceleration, atol=1e-5)


def test_random_multi_sines_stay_within_their_amplitude_and_are_seeded() -> None:
    family = RandomSumOfSines(seeds=[3, 4], terms=4, amplitude=0.5, offsets=0.2)
    first, second = family.references(3)
    again = RandomSumOfSines(seeds=[3], terms=4, amplitude=0.5, offsets=0.2).references(3)[0]
    t = np.linspace(0, 5, 2001)
    np.testing.assert_array_equal(first(t)[0], again(t)[0])
    assert not np.allclose(first(t)[0], second(t)[0])
    assert np.abs(first(t)[0] - 0.2).max() <= 0.5 + 1e-12
    velocity, acceleration = finite_differences(first, TIMES)
    np.testing.assert_allclose(first(TIMES)[1], velocity, atol=1e-7)
    np.testing.assert_allclose(first(TIMES)[2], acceleration, atol=1e-5)


def closed_form(t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A smooth two-joint trajectory with known derivatives."""
    r = np.stack([0.5 * np.sin(1.3 * t), 0.2 * t**2 - 0.1 * np.cos(2.0 * t)], -1)
    rd = np.stack([0.65 * np.cos(1.3 * t), 0.4 * t + 0.2 * np.sin(2.0 * t)], -1)
    rdd = np.stack([-0.845 * np.sin(1.3 * t), 0.4 + 0.4 * np.cos(2.0 * t)], -1)
    return r, rd, rdd


@pytest.mark.parametrize("columns", ["q", "q, qd", "q, qd, qdd"])
@pytest.mark.parametrize("suffix", [".csv", ".npz"])
def test_a_trajectory_file_against_the_closed_form_it_samples(
    tmp_path: Path, columns: str, suffix: str
) -> None:
    """Sampled at 100 Hz from 10 s: the splines give r, ṙ, r̈ between the samples (at
    the 1 kHz control times) within the interpolation error of their order."""
    start = 3.0  # a robot log's clock: shifted to 0
    samples = np.arange(0, 2.0 + 1e-9, 0.01)
    r, rd, rdd = closed_form(samples)
    given = {"q": [r], "q, qd": [r, rd], "q, qd, qdd": [r, rd, rdd]}[columns]
    path = tmp_path / f"trajectory{suffix}"
    if suffix == ".csv":
        header = "t," + ",".join(f"c{i}" for i in range(2 * len(given)))
        np.savetxt(path, np.column_stack([samples + start, *given]), delimiter=",",
                   header=header, comments="")  # fmt: skip
    else:
        names = ("positions", "velocities", "accelerations")
        np.savez(path, time=samples + start, **dict(zip(names, given, strict=False)))
    (reference,) = TrajectoryFile(str(path)).references(2)
    assert reference.duration == pytest.approx(2.0) and reference.label == "trajectory"
    t = np.arange(0.0005, 1.9995, 0.001)
    r_hat, rd_hat, rdd_hat = reference(t)
    r_true, rd_true, rdd_true = closed_form(t)
    np.testing.assert_allclose(r_hat, r_true, atol=1e-6)
    np.testing.assert_allclose(rd_hat, rd_true, atol=2e-4 if columns == "q" else 1e-6)
    np.testing.assert_allclose(rdd_hat, rdd_true, atol=5e-2 if columns == "q" else 5e-3)


BAD_FILES = {
    "time goes back": ("t,q1,q2\n0,0,0\n0.1,0,0\n0.05,0,0\n0.2,0,0\n0.3,0,0\n", "increase"),
    "not finite": ("0,0,0\n0.1,nan,0\n0.2,0,0\n0.3,0,0\n", "not finite"),
    "three joints": ("0,0,0,0\n0.1,0,0,0\n0.2,0,0,0\n0.3,0,0,0\n", "3 value columns"),
    "too short": ("0,0,0\n0.1,0,0\n", "at least 4"),
    "text": ("a,b,c\nx,y,z\n", "not a readable"),
}


@pytest.mark.parametrize("case", list(BAD_FILES))
def test_a_bad_reference_file_is_refused_in_one_line(tmp_path: Path, case: str) -> None:
    text, match = BAD_FILES[case]
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(ConfigError, match=match) as error:
        TrajectoryFile(str(path)).references(2)
    assert "\n" not in str(error.value) and "reference.path" in str(error.value)


@pytest.mark.parametrize(
    ("build", "key"),
    [
        (lambda: SumOfSines([0.1, 0.2], [0.5, 0.5]).references(3), "reference.amplitudes"),
        (lambda: SumOfSines([0.1, [0.2, 0.3]], [0.5, 0.5]).references(2), "reference.frequencies"),
        (lambda: SumOfSines([0.1, 0.2], [0.5, -1.0]).references(2), "reference.frequencies"),
        (lambda: SumOfSines([0.1, float("nan")], [0.5, 1]).references(2), "reference.amplitudes"),
        (lambda: SumOfSines([0.1, 0.2], [0.5, 1], offsets=[1, 2, 3]).references(2),
         "reference.offsets"),
        (lambda: ThesisSines(frequency_mean=[1, 2]).references(3), "reference.frequency_mean"),
        (lambda: ThesisSines(seeds=[]), "reference.seeds"),
        (lambda: TrajectoryFile("missing.csv").references(2), "reference.path"),
        (lambda: TrajectoryFile("trajectory.txt"), "reference.path"),
        (lambda: RandomSumOfSines(frequency_low=2.0, frequency_high=1.0),
         "reference.frequency_high"),
    ],
)  # fmt: skip
def test_bad_references_are_refused_in_one_line(build, key: str) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(ConfigError) as error:
        build()
    assert key in str(error.value) and "\n" not in str(error.value)


class Recorder:
    """Wraps the pybullet module: records every torque command the arm sends."""

    def __init__(self, module) -> None:  # type: ignore[no-untyped-def]
        self._module, self.torques = module, []

    def __getattr__(self, name: str):  # type: ignore[no-untyped-def]
        return getattr(self._module, name)

    def setJointMotorControlArray(self, body, joints, mode, **kwargs):  # type: ignore[no-untyped-def]  # noqa: N802
        if mode == self._module.TORQUE_CONTROL:
            self.torques.append(list(kwargs["forces"]))
        return self._module.setJointMotorControlArray(body, joints, mode, **kwargs)


def test_torque_limits_hold_at_every_step_of_a_tracking_run() -> None:
    """1 rad initial error asks for thousands of N m; the simulator is sent at most the
    limit on every step, the run records what was cut, and its share is reported."""
    limits = np.array([80.0, 120.0, 60.0, 60.0, 20.0, 10.0, 5.0])
    arm = PyBulletArm(torque_limit=limits.tolist())
    recorder = Recorder(arm._pb)
    arm._pb = recorder
    controller = TrueModelFL()
    controller.bind(arm, None)
    (reference,) = ThesisSines(seeds=[0], duration=0.5).references(7)
    run = track(arm, controller, reference, initial_error=1.0)
    sent = np.array(recorder.torques)
    assert len(sent) == len(run.torques)
    assert np.all(np.abs(sent) <= limits + 1e-12)
    np.testing.assert_allclose(sent, run.applied)
    commanded_over = np.abs(run.torques) > limits
    assert commanded_over.any()  # the test would see a limit that is not applied
    metrics = run.metrics(0.2)
    assert metrics["saturated_share"] == pytest.approx(commanded_over.any(axis=1).mean())
    unlimited = PyBulletArm(torque_limit=None)
    assert unlimited.torque_limits is None
    np.testing.assert_array_equal(unlimited.limited(np.full(7, 1e4)), np.full(7, 1e4))
    np.testing.assert_array_equal(PyBulletArm().torque_limits, np.full(7, 300.0))  # the URDF's


def run_control(*overrides: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "runners.control", "controller=true_fl", "threads=1",
         "tracking.mcap=false", *overrides],
        capture_output=True, text=True, timeout=300,
    )  # fmt: skip


def test_the_panda_runs_true_model_fl_with_its_fingers_held(tmp_path: Path) -> None:
    """franka_panda/panda.urdf: 7 revolute joints controlled under its own effort limits
    (87 / 12 N m), the two prismatic fingers held; a gentle multi-sine is tracked."""
    run_dir = tmp_path / "panda"
    result = run_control(
        "robot=panda", "reference=random_sines", "reference.seeds=[0]", "reference.amplitude=0.3",
        "reference.duration=1.5", f"hydra.run.dir={run_dir}",
    )  # fmt: skip
    assert result.returncode == 0, result.stderr[-2000:]
    text = result.stdout + result.stderr
    assert "held joints ['panda_finger_joint1', 'panda_finger_joint2']" in text
    assert "[87.0, 87.0, 87.0, 87.0, 12.0, 12.0, 12.0] N m" in text
    summary = pd.read_csv(run_dir / "summary.csv")
    assert summary["success"].tolist() == [True]
    assert summary["steady_state_max_error_deg_7"].iloc[0] < 0.5


def test_an_arm_refused_in_one_line_and_limits_off_said_so(tmp_path: Path) -> None:
    result = run_control("robot=panda", "robot.num_joints=9", f"hydra.run.dir={tmp_path / 'a'}")
    output = result.stdout + result.stderr
    errors = [line for line in output.splitlines() if "ERROR" in line]
    assert result.returncode != 0 and "Traceback" not in output
    assert len(errors) == 1 and "robot.num_joints=9 but franka_panda/panda.urdf has 7" in errors[0]
    run_dir = tmp_path / "b"
    off = run_control("robot.torque_limit=null", "reference.duration=0.2", "task.settle=0.1",
                      "reference.seeds=[0]", f"hydra.run.dir={run_dir}")  # fmt: skip
    assert off.returncode == 0, off.stderr[-2000:]
    assert "torque limits off (robot.torque_limit=null)" in off.stdout + off.stderr
    assert "torque_limit: null" in (run_dir / "config.yaml").read_text()
