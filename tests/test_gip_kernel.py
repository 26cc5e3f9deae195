"""The GIP kernel (thesis eq. 5.6): a valid covariance, exact gradients, and a GP that
learns an inverse dynamics it can represent (a planar 2-link arm in closed form)."""

from __future__ import annotations

from functools import partial

import numpy as np
import pytest
import torch

from mcpilco.control.data import InverseDynamicsData
from mcpilco.control.inverse_dynamics import GPInverseDynamics
from mcpilco.errors import ConfigError
from mcpilco.kernels import GeometricPolynomial, KernelShape, SquaredExponential


def test_gip_is_a_symmetric_psd_covariance_with_its_diagonal() -> None:
    torch.manual_seed(0)
    kernel = GeometricPolynomial(KernelShape(3, 9), prismatic=[1], offset=0.7, weight=1.3)
    with torch.no_grad():
        kernel.log_joint_weight.normal_(0.0, 0.3)
    x = torch.randn(40, 9, dtype=torch.float64)
    gram = kernel(x, x)
    assert gram.shape == (3, 40, 40)
    torch.testing.assert_close(gram, gram.transpose(-1, -2))
    assert torch.linalg.eigvalsh(gram).min() > -1e-8 * gram.abs().max()
    torch.testing.assert_close(torch.diagonal(gram, dim1=-2, dim2=-1), kernel.diag(x))
    y = torch.randn(7, 9, dtype=torch.float64)
    cross, variance = kernel.prepare(y)(x)
    torch.testing.assert_close(cross, kernel(x, y))
    torch.testing.assert_close(variance, kernel.diag(x))
    shared = x.clone()
    shared[:, [0, 1, 2]] = x[0, [0, 1, 2]]  # one configuration q, many (q̇, q̈): eq. 5.7-5.9
    torch.testing.assert_close(kernel.prepare(y)(shared)[0], kernel(shared, y))


def test_gip_matches_its_formula_at_one_pair() -> None:
    """k = (σa + q̈·wa·q̈') + (σv1 + q̇·wv1·q̇')(σv2 + q̇·wv2·q̇')) × ∏_j ∏_r (σ + w_c cc' + w_s ss')."""
    kernel = GeometricPolynomial(KernelShape(1, 6), offset=0.5, weight=2.0)
    x, z = (
        torch.tensor([[0.3, -1.1, 0.2, 0.5, 1.5, -2.0]]),
        torch.tensor([[1.0, 0.4, -0.7, 0.1, 0.3, 0.9]]),
    )
    x, z = x.double(), z.double()
    acc = 0.5 + 2.0 * (x[0, 4:] * z[0, 4:]).sum()
    vel = (0.5 + 2.0 * (x[0, 2:4] * z[0, 2:4]).sum()) ** 2
    config = 1.0
    for j in range(2):
        a, b = x[0, j], z[0, j]
        config *= (0.5 + 2.0 * (torch.cos(a) * torch.cos(b) + torch.sin(a) * torch.sin(b))) ** 2
    torch.testing.assert_close(kernel(x, z)[0, 0, 0], (acc + vel) * config)


def test_gip_matches_its_formula_with_random_weights_per_factor_and_a_prismatic_joint() -> None:
    """Every output, factor and feature with its own weight, joint 2 of 3 prismatic: a
    mis-indexed factor, feature, output or joint type would change the value."""
    torch.manual_seed(3)
    n, outputs = 3, 2
    kernel = GeometricPolynomial(KernelShape(outputs, 3 * n), prismatic=[1])
    with torch.no_grad():
        for parameter in kernel.parameters():
            parameter.normal_(0.0, 0.5)
    x, z = torch.randn(4, 3 * n, dtype=torch.float64), torch.randn(3, 3 * n, dtype=torch.float64)
    gram = kernel(x, z)

    def features(q: torch.Tensor, joint: int) -> tuple[float, float]:
        return (float(q), 0.0) if joint == 1 else (float(torch.cos(q)), float(torch.sin(q)))

    acc, vel = kernel.acceleration_term, kernel.velocity_term
    for g in range(outputs):
        for a in range(4):
            for b in range(3):
                u, v = x[a], z[b]
                motion = float(acc.log_offset[g, 0].exp()) + sum(
                    float(acc.log_weight[g, 0, d].exp() * u[2 * n + d] * v[2 * n + d])
                    for d in range(n)
                )
                velocity = 1.0
                for r in range(2):
                    velocity *= float(vel.log_offset[g, r].exp()) + sum(
                        float(vel.log_weight[g, r, d].exp() * u[n + d] * v[n + d]) for d in range(n)
                    )
                configuration = 1.0
                for j in range(n):
                    fu, fv = features(u[j], j), features(v[j], j)
                    for r in range(2):
                        configuration *= float(kernel.log_joint_offset[g, j, r].exp()) + sum(
                            float(kernel.log_joint_weight[g, j, r, f].exp()) * fu[f] * fv[f]
                            for f in range(2)
                        )
                expected = (motion + velocity) * configuration
                assert float(gram[g, a, b]) == pytest.approx(expected, rel=1e-10)


def test_gip_gradients_match_finite_differences() -> None:
    torch.manual_seed(1)
    kernel = GeometricPolynomial(KernelShape(2, 6))
    x = torch.randn(5, 6, dtype=torch.float64, requires_grad=True)
    z = torch.randn(4, 6, dtype=torch.float64)
    assert torch.autograd.gradcheck(lambda a: kernel(a, z), (x,))
    parameters = [kernel.log_joint_weight, kernel.log_joint_offset]

    assert torch.autograd.gradcheck(
        lambda w, o: torch.func.functional_call(
            kernel, {"log_joint_weight": w, "log_joint_offset": o}, (x.detach(), z)
        ),
        tuple(p.detach().clone().requires_grad_(True) for p in parameters),
    )


@pytest.mark.parametrize(
    "kwargs",
    [{"positions": [0, 1]}, {"positions": [0], "velocities": [1, 2], "accelerations": [3]},
     {"prismatic": [5]}],
)  # fmt: skip
def test_bad_layout_is_a_one_line_error(kwargs: dict) -> None:
    with pytest.raises(ConfigError, match="GeometricPolynomial"):
        GeometricPolynomial(KernelShape(1, 6), **kwargs)


def two_link_torques(q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
    """Closed-form inverse dynamics of a planar 2-link arm under gravity ``[N, 2]``."""
    m1, m2, l1, c1, c2, i1, i2, g = 1.2, 0.8, 0.6, 0.3, 0.25, 0.05, 0.03, 9.81
    cos2, sin2 = np.cos(q[:, 1]), np.sin(q[:, 1])
    b11 = m1 * c1**2 + m2 * (l1**2 + c2**2 + 2 * l1 * c2 * cos2) + i1 + i2
    b12 = m2 * (c2**2 + l1 * c2 * cos2) + i2
    b22 = m2 * c2**2 + i2
    h = m2 * l1 * c2 * sin2
    gravity1 = (m1 * c1 + m2 * l1) * g * np.cos(q[:, 0]) + m2 * c2 * g * np.cos(q[:, 0] + q[:, 1])
    gravity2 = m2 * c2 * g * np.cos(q[:, 0] + q[:, 1])
    tau1 = b11 * qdd[:, 0] + b12 * qdd[:, 1] - h * (2 * qd[:, 0] * qd[:, 1] + qd[:, 1] ** 2)
    tau2 = b12 * qdd[:, 0] + b22 * qdd[:, 1] + h * qd[:, 0] ** 2
    return np.stack([tau1 + gravity1, tau2 + gravity2], axis=1)


def two_link_data(rng: np.random.Generator, count: int, noise: float) -> InverseDynamicsData:
    q = rng.uniform(-np.pi, np.pi, (count, 2))
    qd, qdd = rng.normal(0, 2, (count, 2)), rng.normal(0, 5, (count, 2))
    torques = two_link_torques(q, qd, qdd) + noise * rng.standard_normal((count, 2))
    return InverseDynamicsData(q, qd, qdd, torques, 0.01)


def test_a_gip_gp_learns_a_two_link_arm_to_the_noise_level() -> None:
    """The 2-link dynamics lies in GIP's function space: with 300 noisy samples the GP's
    held-out error is near the noise (0.01 N m); the SE kernel, given the same data, is far
    from it (an independent contrast, not a tuned threshold)."""
    rng = np.random.default_rng(0)
    train, test = two_link_data(rng, 300, 0.01), two_link_data(rng, 300, 0.0)
    errors = {}
    for name, kernel in (("gip", GeometricPolynomial), ("se", SquaredExponential)):
        model = GPInverseDynamics(partial(kernel), 2, fit_points=None, max_iterations=100)
        model.fit(train, torch.Generator().manual_seed(0))
        predicted = model.torques(torch.as_tensor(test.inputs)).numpy()
        errors[name] = np.sqrt(((predicted - test.torques) ** 2).mean(0))
    assert np.all(errors["gip"] < 0.03), errors
    assert np.all(errors["se"] > 5 * errors["gip"]), errors
