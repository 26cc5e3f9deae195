"""Posterior samples with the gradient formed in the forward pass (mcpilco.gp.forward_gradient)
against the textbook formula differentiated by autograd, finite differences, and the
memory the backward pass keeps."""

from __future__ import annotations

from collections.abc import Callable

import pytest
import torch

from mcpilco.errors import ConfigError
from mcpilco.gp import ExactGP
from mcpilco.kernels import (
    Kernel,
    Linear,
    MultiplicativePolynomial,
    PhysicalBasis,
    SquaredExponential,
    Sum,
)
from tests.test_kernels import SHAPE  # the two-output toy basis of the kernel tests

KERNELS: dict[str, Callable[[], Kernel]] = {
    "se": lambda: SquaredExponential(SHAPE, lengthscale=[0.5, 1.0, 2.0], variance=2.0),
    "se_subset": lambda: SquaredExponential(SHAPE, lengthscale=[0.8, 1.5], active_dims=[0, 2]),
    "physical": lambda: PhysicalBasis(SHAPE, weight=[1.0, 0.5, 0.2]),
    "linear_isotropic": lambda: Linear(SHAPE, weight=0.4, isotropic=True),
    "se_linear_capped": lambda: Sum(
        SHAPE,
        [
            lambda s: SquaredExponential(s, lengthscale=[0.7, 1.2, 0.9]),
            lambda s: Linear(s, weight=[0.5, 2.0], active_dims=[0, 2], max_weight=5.0),
        ],
    ),
    "sp": lambda: Sum(
        SHAPE,
        [lambda s: PhysicalBasis(s, weight=0.3), lambda s: SquaredExponential(s, variance=1.5)],
    ),
}


def make_gp(
    kernel: Kernel, generator: torch.Generator, n: int = 40, noise_std: float = 0.1
) -> ExactGP:
    x = torch.randn(n, 3, generator=generator, dtype=torch.float64)
    y = torch.stack([torch.sin(x[:, 0]) * x[:, 1], torch.cos(x[:, 2]) + x[:, 0]], 1)
    gp = ExactGP(kernel, noise_std=noise_std, noise_std_min=noise_std / 10, forward_gradient=True)
    gp.set_data(x, y)
    return gp


def textbook_sample(gp: ExactGP, x: torch.Tensor, noise: torch.Tensor) -> torch.Tensor:
    """mean + √var ⊙ noise from k(x*, X), k(X, X) and k(x*, x*) with dense solves (the
    kernel's plain forward, no prepared or cached form), floored as the GP floors it."""
    with torch.no_grad():
        gram = gp.kernel(gp.train_inputs, gp.train_inputs)
        gram = gram + gp.noise_variance[:, None, None] * torch.eye(len(gp.train_inputs))
        targets = gp.train_targets.T.unsqueeze(-1)  # [G, N, 1]
    cross = gp.kernel(x, gp.train_inputs)  # [G, M, N]
    mean = torch.matmul(cross, torch.linalg.solve(gram, targets)).squeeze(-1)
    quadratic = (cross * torch.linalg.solve(gram, cross.mT).mT).sum(-1)
    variance = (gp.kernel.diag(x) - quadratic).clamp_min(1e-12)
    return mean + variance.sqrt() * noise


@pytest.mark.parametrize("name", sorted(KERNELS))
def test_sample_and_gradient_match_the_textbook_formula(
    name: str, generator: torch.Generator
) -> None:
    gp = make_gp(KERNELS[name](), generator)
    gp.requires_grad_(False)
    gp.precompute()
    assert gp._prediction_cache(torch.float64).first_order is not None  # the path under test
    x = torch.randn(30, 3, generator=generator, dtype=torch.float64)
    noise = torch.randn(2, 30, generator=generator, dtype=torch.float64)
    weights = torch.randn(2, 30, generator=generator, dtype=torch.float64)
    gradients = []
    for sample in (gp.sample, lambda inputs, eps: textbook_sample(gp, inputs, eps)):
        inputs = x.clone().requires_grad_(True)
        value = sample(inputs, noise)
        (value * weights).sum().backward()
        gradients.append((value.detach(), inputs.grad))
    (ours, our_grad), (reference, reference_grad) = gradients
    torch.testing.assert_close(ours, reference, rtol=1e-9, atol=1e-10)
    torch.testing.assert_close(our_grad, reference_grad, rtol=1e-8, atol=1e-9)


@pytest.mark.parametrize("name", ["se", "sp"])
def test_gradient_matches_finite_differences(name: str, generator: torch.Generator) -> None:
    gp = make_gp(KERNELS[name](), generator, n=15)
    gp.requires_grad_(False)
    x = torch.randn(6, 3, generator=generator, dtype=torch.float64, requires_grad=True)
    noise = torch.randn(2, 6, generator=generator, dtype=torch.float64)
    assert torch.autograd.gradcheck(lambda inputs: gp.sample(inputs, noise), (x,))


def test_a_floored_variance_passes_only_the_mean_gradient(generator: torch.Generator) -> None:
    """At a training input of a near-noiseless GP the variance is floored: the sample's
    gradient is then the mean's alone (the floor is a constant)."""
    gp = make_gp(KERNELS["se"](), generator, n=10, noise_std=1e-7)
    gp.requires_grad_(False)
    x = gp.train_inputs[:4].clone().requires_grad_(True)
    noise = torch.ones(2, 4, dtype=torch.float64)
    gp.sample(x, noise).sum().backward()
    mean_only = x.detach().clone().requires_grad_(True)
    gp.predict(mean_only)[0].sum().backward()
    assert bool((gp.predict(x.detach())[1] <= 1e-12).all())
    torch.testing.assert_close(x.grad, mean_only.grad, rtol=1e-6, atol=1e-8)


def saved_bytes(function: Callable[[], torch.Tensor]) -> int:
    """Bytes of the tensors autograd keeps for the backward pass of ``function()``."""
    total = 0

    def pack(tensor: torch.Tensor) -> torch.Tensor:
        nonlocal total
        total += tensor.numel() * tensor.element_size()
        return tensor

    with torch.autograd.graph.saved_tensors_hooks(pack, lambda tensor: tensor):
        function()
    return total


def test_the_backward_pass_keeps_no_training_set_sized_tensor(generator: torch.Generator) -> None:
    """A rollout keeps what each time step saves: here a few numbers per particle and
    feature, not Γ⁻¹k* and k* (each G·N·M numbers) as the autograd path of a kernel without
    the first-order form does."""
    n, m = 200, 100
    x = torch.randn(m, 3, generator=generator, dtype=torch.float64, requires_grad=True)
    noise = torch.randn(2, m, generator=generator, dtype=torch.float64)
    first_order = make_gp(KERNELS["se"](), generator, n=n)
    polynomial = Sum(SHAPE, [SquaredExponential, lambda s: MultiplicativePolynomial(s, degree=2)])
    plain = make_gp(polynomial, generator, n)
    for gp in (first_order, plain):
        gp.requires_grad_(False)
    assert plain._prediction_cache(torch.float64).first_order is None
    one_tensor = 2 * n * m * 8  # bytes of one [G, N, M] float64 tensor
    assert saved_bytes(lambda: first_order.sample(x, noise)) < one_tensor / 20
    assert saved_bytes(lambda: plain.sample(x, noise)) >= 2 * one_tensor


def test_forward_gradient_can_be_switched_off_and_is_checked(generator: torch.Generator) -> None:
    """``gp.forward_gradient=false`` samples through autograd: the same values and gradient."""
    x = torch.randn(20, 3, generator=generator, dtype=torch.float64)
    noise = torch.randn(2, 20, generator=generator, dtype=torch.float64)
    results = []
    for flag in (True, False):
        gp = make_gp(KERNELS["sp"](), torch.Generator().manual_seed(5))
        gp.forward_gradient = flag
        gp.requires_grad_(False)
        assert (gp._prediction_cache(torch.float64).first_order is not None) == flag
        inputs = x.clone().requires_grad_(True)
        value = gp.sample(inputs, noise)
        value.sum().backward()
        results.append((value.detach(), inputs.grad))
    torch.testing.assert_close(results[0][0], results[1][0], rtol=1e-10, atol=1e-12)
    torch.testing.assert_close(results[0][1], results[1][1], rtol=1e-8, atol=1e-10)
    with pytest.raises(ConfigError, match=r"gp.forward_gradient must be true or false, got 'yes'"):
        ExactGP(KERNELS["se"](), forward_gradient="yes")  # type: ignore[arg-type]
