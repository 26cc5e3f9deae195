"""Kernels: closed forms, symmetry, positive semi-definiteness and gradients."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from torch.autograd import gradcheck

from mcpilco.kernels import (
    Constant,
    KernelShape,
    Linear,
    MultiplicativePolynomial,
    PhysicalBasis,
    SquaredExponential,
    Sum,
)
from mcpilco.kernels.base import COLUMN_MAJOR_FROM
from mcpilco.kernels.se import _PreparedCross


def basis(x: torch.Tensor) -> torch.Tensor:
    """A two-output toy basis [G=2, N, P=3]."""
    return torch.stack(
        [
            torch.stack([x[:, 0] * x[:, 1], torch.sin(x[:, 2]), x[:, 0]], -1),
            torch.stack([x[:, 1] ** 2, torch.cos(x[:, 0]), x[:, 2]], -1),
        ]
    )


SHAPE = KernelShape(num_outputs=2, input_dim=3, basis=basis)

KERNELS = {
    "se": lambda: SquaredExponential(SHAPE, lengthscale=[0.5, 1.0, 2.0], variance=2.0),
    "poly2": lambda: MultiplicativePolynomial(SHAPE, degree=2, offset=0.5, weight=[0.3, 0.2, 0.1]),
    "linear_subset": lambda: Linear(SHAPE, weight=[0.5, 2.0], active_dims=[0, 2]),
    "linear_capped": lambda: Linear(SHAPE, weight=[0.5, 2.0, 1.0], max_weight=5.0),
    "physical": lambda: PhysicalBasis(SHAPE, weight=[1.0, 0.5, 0.2]),
    "sp": lambda: Sum(SHAPE, [lambda s: PhysicalBasis(s), lambda s: SquaredExponential(s)]),
    "se_isotropic": lambda: SquaredExponential(SHAPE, lengthscale=0.7, isotropic=True),
    "linear_isotropic": lambda: Linear(SHAPE, weight=0.4, isotropic=True),
    "linear_bias": lambda: Sum(SHAPE, [lambda s: Linear(s), lambda s: Constant(s, value=0.3)]),
    "se_p2": lambda: Sum(
        SHAPE, [lambda s: SquaredExponential(s), lambda s: MultiplicativePolynomial(s, degree=2)]
    ),
}


@pytest.fixture
def inputs(generator: torch.Generator) -> torch.Tensor:
    return torch.randn(12, 3, generator=generator, dtype=torch.float64)


@pytest.mark.parametrize("name", sorted(KERNELS))
def test_symmetric_psd_and_diag(name: str, inputs: torch.Tensor) -> None:
    kernel = KERNELS[name]()
    gram = kernel(inputs, inputs).detach()
    assert gram.shape == (2, 12, 12)
    torch.testing.assert_close(gram, gram.transpose(-1, -2))
    assert torch.linalg.eigvalsh(gram).min() > -1e-9 * gram.abs().max()
    torch.testing.assert_close(kernel.diag(inputs), torch.diagonal(gram, dim1=-2, dim2=-1))


@pytest.mark.parametrize("name", sorted(KERNELS))
def test_prepared_kernel_equals_forward(name: str, inputs: torch.Tensor) -> None:
    kernel = KERNELS[name]()
    cross, prior = kernel.prepare(inputs[:5])(inputs)
    torch.testing.assert_close(cross, kernel(inputs, inputs[:5]))
    torch.testing.assert_close(prior, kernel.diag(inputs))
    # a particle batch comes column-major, the layout the predictions' solves take
    # without a copy (PreparedKernel); fewer points may come row-major (cross_product)
    batch = torch.randn(COLUMN_MAJOR_FROM, 3, generator=torch.Generator().manual_seed(3))
    cross, _ = kernel.prepare(inputs[:5])(batch.to(inputs.dtype))
    torch.testing.assert_close(cross, kernel(batch.to(inputs.dtype), inputs[:5]))
    assert cross.mT.is_contiguous(), cross.stride()


@pytest.mark.parametrize("name", sorted(KERNELS))
def test_gradcheck_inputs_and_hyperparameters(name: str, inputs: torch.Tensor) -> None:
    kernel = KERNELS[name]()
    x1 = inputs[:4].clone().requires_grad_()
    x2 = inputs[4:7].clone().requires_grad_()
    assert gradcheck(lambda a, b: kernel(a, b), (x1, x2))
    names = [n for n, p in kernel.named_parameters() if p.requires_grad]
    values = tuple(kernel.get_parameter(n).detach().clone().requires_grad_() for n in names)

    def gram_of(*hyper: torch.Tensor) -> torch.Tensor:
        return torch.func.functional_call(
            kernel, dict(zip(names, hyper, strict=True)), (inputs[:4], inputs[4:7])
        )

    assert gradcheck(gram_of, values)


def test_se_matches_numpy(inputs: torch.Tensor) -> None:
    kernel = KERNELS["se"]()
    x = inputs.numpy()
    diff = (x[:, None] - x[None]) / np.array([0.5, 1.0, 2.0])
    expected = 2.0 * np.exp(-(diff**2).sum(-1))
    np.testing.assert_allclose(kernel(inputs, inputs)[1].detach().numpy(), expected, rtol=1e-12)


def test_polynomial_matches_explicit_product(inputs: torch.Tensor) -> None:
    kernel = KERNELS["poly2"]()
    x = inputs.numpy()
    weight = np.array([0.3, 0.2, 0.1])
    expected = (0.5 + (x * weight) @ x.T) ** 2
    np.testing.assert_allclose(kernel(inputs, inputs)[0].detach().numpy(), expected, rtol=1e-12)


def test_linear_subset_ignores_other_inputs(inputs: torch.Tensor) -> None:
    kernel = KERNELS["linear_subset"]()
    moved = inputs.clone()
    moved[:, 1] += 5.0
    torch.testing.assert_close(kernel(inputs, inputs), kernel(moved, moved))


def test_se_prepared_cross_gradcheck(generator: torch.Generator) -> None:
    x = torch.randn(5, 3, generator=generator, dtype=torch.float64, requires_grad=True)
    inverse = 0.5 + torch.rand(2, 1, 3, generator=generator, dtype=torch.float64)
    training = torch.randn(2, 4, 5, generator=generator, dtype=torch.float64)  # [G, N, D+2]
    assert gradcheck(lambda a: _PreparedCross.apply(a, inverse, training), (x,))


def test_capped_linear_starts_at_its_weights_and_stays_below_the_cap(
    inputs: torch.Tensor,
) -> None:
    capped = Linear(SHAPE, weight=[0.5, 2.0, 1.0], max_weight=5.0)
    free = Linear(SHAPE, weight=[0.5, 2.0, 1.0])
    torch.testing.assert_close(capped(inputs, inputs), free(inputs, inputs))
    # x Σ xᵀ with Σ = diag(weights), against the explicit product
    sigma = torch.diag(torch.tensor([0.5, 2.0, 1.0], dtype=torch.float64))
    torch.testing.assert_close(capped(inputs, inputs)[0], inputs @ sigma @ inputs.T)
    with torch.no_grad():
        capped.log_weight.fill_(50.0)
    assert torch.all(capped.weights() <= 5.0)
    torch.testing.assert_close(capped.weights(), torch.full((2, 3), 5.0, dtype=torch.float64))


def test_capped_linear_weight_of_a_flat_column_stays_bounded_in_a_fit(
    generator: torch.Generator,
) -> None:
    """A column of tiny values (1e-4) that follows what the other inputs leave unexplained
    (as the UR5's wrist torques, ~1e-3, react to its tracking errors): marginal likelihood
    explains the residual with that column's slope, ~100, i.e. a weight ~1e4; the cap
    holds it."""
    from mcpilco.gp import ExactGP, MarginalLikelihoodFit

    shape = KernelShape(num_outputs=1, input_dim=2)
    x = torch.randn(60, 2, generator=generator, dtype=torch.float64)
    residual = 1e-2 * torch.sin(3.0 * x[:, 0])
    x[:, 1] = 1e-2 * residual
    noise = 1e-3 * torch.randn(60, generator=generator, dtype=torch.float64)
    y = (2.0 * x[:, 0] + residual + noise)[:, None]
    weights = {}
    for cap in (None, 100.0):
        gp = ExactGP(Linear(shape, max_weight=cap), noise_std=0.1)
        gp.set_data(x, y)
        MarginalLikelihoodFit()(gp)
        weights[cap] = gp.hyperparameters()["weight"][0]
        mean, _ = gp.predict(x)
        # either way the fit keeps the main slope: within the residual's 1e-2 of 2 x0
        assert float((mean[0].detach() - 2.0 * x[:, 0]).abs().max()) < 0.03  # mean [G, N]
    assert weights[None][1] > 1e3
    assert weights[100.0][1] <= 100.0
    with pytest.raises(Exception, match="max_weight"):
        Linear(shape, weight=2.0, max_weight=1.0)


def test_isotropic_kernels_equal_ard_ones_with_equal_parameters(inputs: torch.Tensor) -> None:
    """Thesis eq. 6.6/6.9: one length-scale (weight) for all inputs."""
    iso = SquaredExponential(SHAPE, lengthscale=0.7, variance=1.5, isotropic=True)
    ard = SquaredExponential(SHAPE, lengthscale=[0.7] * 3, variance=1.5)
    assert iso.log_lengthscale.shape == (2, 1)
    torch.testing.assert_close(iso(inputs, inputs[:5]), ard(inputs, inputs[:5]))
    linear_iso = Linear(SHAPE, weight=0.4, isotropic=True)
    expected = 0.4 * inputs @ inputs[:5].T
    torch.testing.assert_close(linear_iso(inputs, inputs[:5])[1], expected)
    torch.testing.assert_close(linear_iso.diag(inputs)[0], 0.4 * inputs.square().sum(-1))


def test_linear_plus_constant_is_the_inhomogeneous_linear_kernel(inputs: torch.Tensor) -> None:
    """Thesis eq. 6.10: [x, 1] diag(phi^2) [x', 1]^T."""
    kernel = Sum(
        SHAPE, [lambda s: Linear(s, weight=[0.5, 2.0, 1.0]), lambda s: Constant(s, value=0.3)]
    )
    augmented = torch.cat([inputs, torch.ones(len(inputs), 1, dtype=inputs.dtype)], 1)
    phi = torch.diag(torch.tensor([0.5, 2.0, 1.0, 0.3], dtype=inputs.dtype))
    torch.testing.assert_close(kernel(inputs, inputs)[0], augmented @ phi @ augmented.T)
