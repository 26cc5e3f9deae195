"""GP feedback-linearisation control of the PyBullet iiwa (thesis chapter 5)."""

from __future__ import annotations

import json
import subprocess
import sys
from functools import partial
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import torch

from mcpilco.control import (
    GPFL,
    GPFLDCE,
    GPInverseDynamics,
    InverseDynamicsData,
    PyBulletArm,
    SineReference,
    TrueModelFL,
    track,
)
from mcpilco.errors import ConfigError
from mcpilco.kernels import GeometricPolynomial
from mcpilco.kernels.base import KernelShape
from mcpilco.tracking import read_run_log

ROOT = Path(__file__).resolve().parent.parent

SLOW = pytest.mark.slow
"""End-to-end cases beside a faster one of the same guarantee (make test-slow)."""


@pytest.fixture(scope="module")
def arm() -> PyBulletArm:
    return PyBulletArm()


def test_pybullet_arm_is_torque_controlled_with_an_exact_true_model(arm: PyBulletArm) -> None:
    """One 1 ms step under τ = ID(q, q̇, q̈*) gives q̈* (semi-implicit Euler), B(q) is
    symmetric positive definite and τ is linear in q̈ with it."""
    rng = np.random.default_rng(0)
    for _ in range(5):
        q, qd, target = rng.uniform(-1, 1, 7), rng.uniform(-1, 1, 7), rng.uniform(-5, 5, 7)
        arm.reset(q, qd)
        _, qd_next = arm.step(arm.inverse_dynamics(q, qd, target))
        np.testing.assert_allclose((qd_next - qd) / arm.dt, target, atol=1e-8)
        inertia = arm.mass_matrix(q)
        np.testing.assert_allclose(inertia, inertia.T)
        assert np.linalg.eigvalsh(inertia).min() > 0
        bias = arm.inverse_dynamics(q, qd, np.zeros(7))
        np.testing.assert_allclose(inertia @ target + bias, arm.inverse_dynamics(q, qd, target))
    with pytest.raises(ConfigError, match=r"robot.num_joints=6 but .* has 7 revolute joints"):
        PyBulletArm(num_joints=6)
    for key in ("dt", "joint_damping"):
        with pytest.raises(ConfigError, match=f"robot.{key} must be"):
            PyBulletArm(**{key: -1.0})


def test_true_model_controller_tracks_within_a_hundredth_of_a_radian(arm: PyBulletArm) -> None:
    controller = TrueModelFL()
    controller.bind(arm, None)
    for seed in (0, 1):
        reference = SineReference.random(np.random.default_rng(seed), 7)
        run = track(arm, controller, reference, 2.0, initial_error=0.1)
        assert not run.diverged
        assert np.abs(run.errors[run.time >= 0.5]).max() < 0.01
        np.testing.assert_allclose(run.errors[0], 0.1)


def test_reference_derivatives_match_finite_differences() -> None:
    reference = SineReference(0.165, np.array([0.3, -1.2, 2.0]))
    t, h = np.array([0.4, 1.7, 4.2]), 1e-6
    r, rd, rdd = reference(t)
    np.testing.assert_allclose(rd, (reference(t + h)[0] - reference(t - h)[0]) / (2 * h), atol=1e-6)
    np.testing.assert_allclose(
        rdd, (reference(t + h)[1] - reference(t - h)[1]) / (2 * h), atol=1e-5
    )
    np.testing.assert_allclose(
        r, 0.165 * t[:, None] * np.sin(2 * np.pi * reference.frequencies * t[:, None])
    )


class LinearModel:
    """A stand-in GP: f(q, q̇, q̈) = M q̈ + c(q, q̇), M fixed (what a GP mean is, locally)."""

    num_joints = 2
    _step_weights = None  # GPInverseDynamics.components then evaluates the n + 2 rows

    def __init__(self) -> None:
        self.inertia = torch.tensor([[2.0, 0.3], [0.3, 1.0]], dtype=torch.float64)
        self.calls: list[torch.Tensor] = []

    def bias(self, q: torch.Tensor, qd: torch.Tensor) -> torch.Tensor:
        return torch.stack([torch.sin(q[..., 0]) + qd[..., 1] ** 2, q[..., 1] * qd[..., 0]], -1)

    def torques(self, inputs: torch.Tensor) -> torch.Tensor:
        self.calls.append(inputs)
        q, qd, qdd = inputs[:, :2], inputs[:, 2:4], inputs[:, 4:]
        return qdd @ self.inertia.T + self.bias(q, qd)

    components_inputs = GPInverseDynamics.components_inputs
    components = GPInverseDynamics.components


def test_controller_laws_and_gains_on_a_scripted_state() -> None:
    """a = r̈ + ω²(r − q) + 2ζω(ṙ − q̇); GP-FL feeds [q, q̇, a] to the GP, GP-FL-DCE builds
    B̂ a + n̂ from one batched call of n + 2 points (eq. 5.7–5.9)."""
    q, qd = np.array([0.2, -0.4]), np.array([1.0, 0.5])
    reference = (np.array([0.25, -0.3]), np.array([0.8, 0.7]), np.array([3.0, -2.0]))
    omega, zeta = 100.0, 2.0
    expected_a = (
        reference[2] + omega**2 * (reference[0] - q) + 2 * zeta * omega * (reference[1] - qd)
    )
    model = LinearModel()
    gp_fl, dce = GPFL(omega, zeta), GPFLDCE(omega, zeta)
    for controller in (gp_fl, dce):
        controller.bind(None, model)  # type: ignore[arg-type]
        np.testing.assert_allclose(controller.acceleration(q, qd, reference), expected_a)
    expected_tau = (
        model.inertia.numpy() @ expected_a + model.bias(torch.tensor(q), torch.tensor(qd)).numpy()
    )
    np.testing.assert_allclose(gp_fl(q, qd, reference), expected_tau)
    np.testing.assert_allclose(model.calls[-1][0].numpy(), np.concatenate([q, qd, expected_a]))
    np.testing.assert_allclose(dce(q, qd, reference), expected_tau)
    batch = model.calls[-1].numpy()
    assert batch.shape == (4, 6)  # ĝ, two columns of B̂, n̂: one call
    np.testing.assert_allclose(batch[1:3, 4:], np.eye(2))
    inertia, bias, gravity = GPInverseDynamics.components(model, torch.tensor(q), torch.tensor(qd))
    np.testing.assert_allclose(inertia.numpy(), model.inertia.numpy())
    for key in ("omega", "zeta"):
        for bad in (0.0, -1.0, float("nan")):
            with pytest.raises(ConfigError, match=f"controller.{key}"):
                GPFL(**{key: bad})


HELD = np.array([0.0, 0.0, 0.0, 0.6, -0.4, 0.8, 0.2])
"""Joints 4-7 held here (rad) in the component test: with joints 1-3 moving, a GIP GP
learns the 7-joint dynamics from 800 samples in well under a minute; all 7 moving needs
~800 ML-II points and ~10 minutes for the same accuracy (measured)."""


def true_dynamics_data(
    arm: PyBulletArm, rng: np.random.Generator, count: int
) -> InverseDynamicsData:
    """PyBullet's own inverse dynamics at random (q, q̇, q̈): joints 1-3 move, 4-7 are
    held at ``HELD`` (all seven accelerate, so every column of B(q) is excited)."""
    q = np.tile(HELD, (count, 1))
    q[:, :3] = rng.uniform(-1.5, 1.5, (count, 3))
    qd = np.zeros((count, 7))
    qd[:, :3] = rng.normal(0, 1, (count, 3))
    qdd = rng.normal(0, 5, (count, 7))
    torques = np.array([arm.inverse_dynamics(*sample) for sample in zip(q, qd, qdd, strict=True)])
    return InverseDynamicsData(q, qd, qdd, torques, 0.01)


def test_components_from_a_gp_of_the_true_inverse_dynamics_match_pybullet(arm: PyBulletArm) -> None:
    """ĝ(q) and B̂(q) (eq. 5.7-5.8) of a GIP GP trained on PyBullet's own inverse
    dynamics, at 10 held-out configurations, against PyBullet's gravity torques and mass
    matrix: within 5 % of the largest entry (measured: 0.5 % and 1.1 %)."""
    rng = np.random.default_rng(0)
    model = GPInverseDynamics(partial(GeometricPolynomial), 7, fit_points=300, max_iterations=100)
    model.fit(true_dynamics_data(arm, rng, 800), torch.Generator().manual_seed(0))
    gravity_errors, inertia_errors, gravity_scale, inertia_scale = [], [], [], []
    for moving in rng.uniform(-1.5, 1.5, (10, 3)):
        q = HELD.copy()
        q[:3] = moving
        inertia, _, gravity = model.components(torch.tensor(q), torch.zeros(7, dtype=torch.float64))
        true_gravity, true_inertia = arm.gravity_torques(q), arm.mass_matrix(q)
        gravity_errors.append(np.abs(gravity.numpy() - true_gravity).max())
        inertia_errors.append(np.abs(inertia.numpy() - true_inertia).max())
        gravity_scale.append(np.abs(true_gravity).max())
        inertia_scale.append(np.abs(true_inertia).max())
    assert max(gravity_errors) < 0.05 * max(gravity_scale), (gravity_errors, gravity_scale)
    assert max(inertia_errors) < 0.05 * max(inertia_scale), (inertia_errors, inertia_scale)


class NonSymmetricModel(LinearModel):
    """f = M q̈ + c(q, q̇) with a non-symmetric M: a transposed B̂ would not pass."""

    def __init__(self) -> None:
        super().__init__()
        self.inertia = torch.tensor([[2.0, 0.7], [-0.3, 1.0]], dtype=torch.float64)


def test_the_inertia_estimate_is_not_transposed() -> None:
    """B̂_ij = f̂_i(q, 0, 1_j) − ĝ_i: row i is joint i's torque, column j the unit
    acceleration of joint j (eq. 5.8), and GP-FL-DCE's τ = B̂ a + n̂ uses it so."""
    model = NonSymmetricModel()
    q, qd = torch.tensor([0.3, -0.2], dtype=torch.float64), torch.tensor([0.5, 1.5])
    inertia, bias, gravity = GPInverseDynamics.components(model, q, qd.double())
    np.testing.assert_allclose(inertia.numpy(), model.inertia.numpy())
    np.testing.assert_allclose(gravity.numpy(), model.bias(q, torch.zeros(2)).numpy())
    dce = GPFLDCE()
    dce.bind(None, model)  # type: ignore[arg-type]
    a = np.array([3.0, -7.0])
    expected = model.inertia.numpy() @ a + model.bias(q, qd.double()).numpy()
    np.testing.assert_allclose(dce.torque(q.numpy(), qd.numpy(), a), expected)


@pytest.mark.parametrize(
    "options", [{}, {"active_dims": [0, 1, 3, 4, 5]}, {"isotropic": True, "lengthscale": 0.7}]
)
def test_se_step_factors_against_the_kernel_rows(options: dict[str, object]) -> None:
    """k(x + s e_c, X) = k(x, X) ⊙ F_c for x with x_c = 0, from the kernel's own rows;
    a column outside active_dims gives F = 1."""
    from mcpilco.kernels import SquaredExponential

    kernel = SquaredExponential(KernelShape(3, 6), **options)  # type: ignore[arg-type]
    with torch.no_grad():
        for parameter in kernel.parameters():
            parameter.add_(0.3 * torch.randn(parameter.shape, dtype=parameter.dtype))
    generator = torch.Generator().manual_seed(0)
    x2 = torch.randn(40, 6, dtype=torch.float64, generator=generator)
    x = torch.randn(1, 6, dtype=torch.float64, generator=generator)
    columns, steps = [2, 3, 5], [0.4, -1.3, 2.0]
    factors = kernel.step_factors(x2, columns, steps)
    for i, (column, step) in enumerate(zip(columns, steps, strict=True)):
        base, moved = x.clone(), x.clone()
        base[0, column], moved[0, column] = 0.0, step
        expected = kernel(moved, x2)[:, 0]
        torch.testing.assert_close(kernel(base, x2)[:, 0] * factors[:, i], expected)


def test_se_components_from_two_rows_equal_the_n_plus_2_rows(arm: PyBulletArm) -> None:
    """GPInverseDynamics.components with the SE step factors (two kernel rows) against
    f̂ evaluated at the n + 2 rows [q, 0, 0], [q, 0, 1_j], [q, q̇, 0] directly."""
    from mcpilco.kernels import SquaredExponential

    rng = np.random.default_rng(5)
    model = GPInverseDynamics(partial(SquaredExponential), 7)
    model.condition(true_dynamics_data(arm, rng, 200))
    assert model._step_weights is not None
    for _ in range(3):
        q, qd = torch.tensor(rng.uniform(-1, 1, 7)), torch.tensor(rng.normal(0, 1, 7))
        values = model.torques(model.components_inputs(q, qd))  # the n + 2 rows
        inertia, bias, gravity = model.components(q, qd)
        scale = values.abs().max().item()
        torch.testing.assert_close(gravity, values[0], rtol=0, atol=1e-9 * scale)
        torch.testing.assert_close(inertia, (values[1:-1] - values[0]).T, rtol=0, atol=1e-9 * scale)
        torch.testing.assert_close(bias, values[-1], rtol=0, atol=1e-9 * scale)


def test_float32_prediction_is_refused_where_it_changes_the_torques(arm: PyBulletArm) -> None:
    """An ill-conditioned SE posterior (smooth kernel, tiny noise: α cancels) changes in
    float32 and binding a float32 controller to it fails in one line naming the key; a GIP
    posterior on the same data predicts in float32 within 1e-4 of its torque scale."""
    from mcpilco.kernels import SquaredExponential

    data = true_dynamics_data(arm, np.random.default_rng(6), 1000)
    smooth = GPInverseDynamics(partial(SquaredExponential, lengthscale=10.0), 7, noise_std=1e-3)
    smooth.condition(data)
    with pytest.raises(ConfigError, match=r"^controller\.prediction_dtype: float32 prediction"):
        GPFL(prediction_dtype="float32").bind(arm, smooth)
    gip = GPInverseDynamics(partial(GeometricPolynomial), 7)
    gip.condition(data)
    inputs = torch.as_tensor(data.inputs[:50])
    exact = gip.torques(inputs)
    GPFL(prediction_dtype="float32").bind(arm, gip)
    difference = (gip.torques(inputs) - exact).abs().max()
    assert 0 < difference < 1e-4 * exact.abs().max(), difference


@pytest.mark.parametrize("kernel", ["gip", "se"])
def test_gp_fl_equals_gp_fl_dce_exactly_under_gip_only(arm: PyBulletArm, kernel: str) -> None:
    """Thesis §5.4.2: a GIP model is affine in q̈, so f̂(q, q̇, a) = B̂(q) a + n̂(q, q̇) and
    the two controllers command the same torque; an SE model is not (they differ)."""
    from mcpilco.kernels import SquaredExponential

    factory = partial(GeometricPolynomial if kernel == "gip" else SquaredExponential)
    rng = np.random.default_rng(4)
    model = GPInverseDynamics(factory, 7)
    with torch.no_grad():
        for parameter in model.gp.kernel.parameters():
            parameter.add_(0.3 * torch.randn(parameter.shape, dtype=parameter.dtype))
    model.condition(true_dynamics_data(arm, rng, 200))
    gp_fl, dce = GPFL(), GPFLDCE()
    for controller in (gp_fl, dce):
        controller.bind(arm, model)
    assert model.affine_in_accelerations == (kernel == "gip")
    for _ in range(5):
        q, qd = rng.uniform(-1, 1, 7), rng.normal(0, 1, 7)
        reference = (q + rng.normal(0, 0.01, 7), qd + rng.normal(0, 0.1, 7), rng.normal(0, 5, 7))
        first, second = gp_fl(q, qd, reference), dce(q, qd, reference)
        inertia, bias, _ = model.components(torch.tensor(q), torch.tensor(qd))
        composed = inertia.numpy() @ gp_fl.acceleration(q, qd, reference) + bias.numpy()
        np.testing.assert_allclose(second, first if kernel == "gip" else composed, rtol=1e-12)
        if kernel == "gip":  # the algebra: f̂(q, q̇, a) = B̂ a + n̂ from n + 2 GP rows
            np.testing.assert_allclose(first, composed, rtol=1e-9, atol=1e-9 * np.abs(first).max())
        else:
            assert np.abs(first - composed).max() > 1e-6 * np.abs(first).max()


TINY = [
    "data.duration=2.0",
    "gp.fit_points=100",
    "gp.max_iterations=5",
    "reference.duration=0.3",
    "task.settle=0.2",
    "reference.seeds=[0]",
    "threads=1",
]


def run_control(*overrides: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "runners.control", *overrides],
        cwd=Path.cwd(), capture_output=True, text=True, timeout=600,
    )  # fmt: skip


def errors_in(result: subprocess.CompletedProcess[str]) -> list[str]:
    return [line for line in (result.stdout + result.stderr).splitlines() if "ERROR" in line]


def test_runner_fits_once_and_reuses_the_model(tmp_path: Path) -> None:
    models = tmp_path / "model"
    first = run_control(
        *TINY, "controller=gp_fl", f"model_dir={models}", f"hydra.run.dir={tmp_path / 'a'}"
    )
    assert first.returncode == 0, first.stderr[-3000:]
    meta = json.loads((models / "model.json").read_text())
    assert meta["robot"].startswith("PyBulletArm(kuka_iiwa") and len(meta["nmse_percent"]) == 7
    assert meta["fit"]["fit_points"] == 100 and meta["fit"]["posterior_points"] == 200
    stamp = (models / "gp.pt").stat().st_mtime_ns
    second = run_control(
        *TINY, "controller=gp_fl_dce", "fit_model=false", f"model_dir={models}",
        f"hydra.run.dir={tmp_path / 'b'}", "tracking.rerun=save",
    )  # fmt: skip
    assert second.returncode == 0, second.stderr[-3000:]
    assert (models / "gp.pt").stat().st_mtime_ns == stamp  # loaded, not refitted
    summary = pd.read_csv(tmp_path / "b" / "summary.csv")
    assert summary["seed"].tolist() == [0] and "steady_state_max_error_deg_7" in summary
    with np.load(tmp_path / "b" / "tracking" / "seed_00.npz") as arrays:
        assert arrays["positions"].shape == (301, 7) and arrays["torques"].shape == (300, 7)
    log = read_run_log(tmp_path / "b")
    assert len(log.rollout(0)) == 301 and log.rollout(0)["kind"].iloc[0] == "tracking"
    data_log = read_run_log(models)
    assert set(data_log.rollouts["kind"]) == {"train", "test"}
    replay = subprocess.run(
        [sys.executable, "-m", "runners.replay", str(tmp_path / "b")],
        cwd=Path.cwd(), capture_output=True, text=True, timeout=600,
    )  # fmt: skip
    assert replay.returncode == 0, replay.stderr[-2000:]
    assert (tmp_path / "b" / "recording.rrd").is_file()


@pytest.mark.parametrize(
    ("overrides", "message"),
    [
        (["robot.num_joints=6"], "robot.num_joints=6 but"),
        # slow: CI time; every key's bad values are also refused in-process
        # (tests/test_runner_config_checks.py)
        pytest.param(["controller.omega=0"], "controller.omega must be positive", marks=SLOW),
        pytest.param(["robot.dt=-0.001"], "robot.dt must be positive", marks=SLOW),
        (["fit_model=false"], "holds no fitted model and fit_model=false"),
        pytest.param(["reference.seeds=[]"], "reference.seeds", marks=SLOW),
        pytest.param(
            ["tracking.rerun=connect"], "tracking.rerun='connect' must be off or save", marks=SLOW
        ),
    ],
)
def test_bad_input_stops_before_any_simulation(
    tmp_path: Path, overrides: list[str], message: str
) -> None:
    result = run_control(
        *TINY, *overrides, f"model_dir={tmp_path / 'm'}", f"hydra.run.dir={tmp_path / 'r'}"
    )
    assert result.returncode == 2, result.stderr[-2000:]
    errors = errors_in(result)
    assert len(errors) == 1 and message in errors[0], errors
    assert not (tmp_path / "m" / "data").exists() and not (tmp_path / "r" / "summary.csv").exists()


@pytest.mark.parametrize(
    ("key", "value"),
    [
        pytest.param("robot", "PyBulletArm(other.urdf, 7 joints)", marks=pytest.mark.slow),
        ("kernel", {}),
    ],
)
def test_a_model_fitted_to_another_robot_or_kernel_is_refused(
    tmp_path: Path, key: str, value: object
) -> None:
    models = tmp_path / "m"
    first = run_control(
        *TINY, "controller=gp_fl", f"model_dir={models}", f"hydra.run.dir={tmp_path / 'a'}"
    )
    assert first.returncode == 0, first.stderr[-2000:]
    meta = json.loads((models / "model.json").read_text())
    meta[key] = value
    (models / "model.json").write_text(json.dumps(meta))
    result = run_control(*TINY, f"model_dir={models}", f"hydra.run.dir={tmp_path / 'b'}")
    assert result.returncode == 2
    errors = errors_in(result)
    assert len(errors) == 1 and f"holds a model fitted with a different {key}" in errors[0]
