"""Squashed-RBF policy: formula, bound, dropout statistics and hand-written gradient."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from torch.autograd import gradcheck

from mcpilco.errors import ConfigError
from mcpilco.policies import SquashedRBFPolicy, UniformRandomExploration
from mcpilco.policies.rbf_network import SquashedRBFFunction


def make_policy(generator: torch.Generator, u_max: float = 3.0) -> SquashedRBFPolicy:
    return SquashedRBFPolicy(4, 2, u_max, num_basis=20, lengthscale=0.8, generator=generator)


def test_matches_numpy_formula(generator: torch.Generator) -> None:
    policy = make_policy(generator)
    x = torch.randn(6, 4, generator=generator, dtype=torch.float64)
    centres, weights = policy.centres.detach().numpy(), policy.weights.detach().numpy()
    ell = np.exp(policy.log_lengthscale.detach().numpy())
    distances = (((x.numpy()[:, None, :] - centres[None]) / ell) ** 2).sum(-1)
    expected = 3.0 * np.tanh(np.exp(-distances) @ weights / 3.0)
    np.testing.assert_allclose(policy(x).detach().numpy(), expected, rtol=1e-12)


def test_output_bounded_by_u_max(generator: torch.Generator) -> None:
    policy = make_policy(generator, u_max=2.5)
    with torch.no_grad():
        policy.weights.mul_(1e6)
    x = 3.0 * torch.randn(500, 4, generator=generator, dtype=torch.float64)
    actions = policy(x)
    assert actions.abs().max() <= 2.5
    assert actions.abs().max() > 2.4  # saturates, not clipped to something smaller


def test_dropout_rate_and_scaling(generator: torch.Generator) -> None:
    policy = make_policy(generator)
    bits = policy.dropout_bits(50, 400, generator)
    for probability in (0.25, 0.125):
        dropped = (bits < round(256 * probability)).double().mean()
        assert float(dropped) == pytest.approx(probability, abs=0.005)
        # every byte of the underlying 64-bit draws is uniform (no biased top byte)
        by_position = (bits.reshape(-1, 8) < round(256 * probability)).double().mean(0)
        torch.testing.assert_close(
            by_position, torch.full_like(by_position, probability), atol=0.01, rtol=0.0
        )
    # The expected pre-squash output under dropout equals the deterministic one.
    x = torch.randn(1, 4, generator=generator, dtype=torch.float64).expand(20000, 4)
    many_bits = policy.dropout_bits(1, 20000, generator)[0]
    with torch.no_grad():
        policy.weights.mul_(1e-3)  # stay in tanh's linear range
        mean_dropped = policy(x, many_bits, 0.25).mean(0)
        deterministic = policy(x[:1])[0]
    scale = float(deterministic.abs().max())
    torch.testing.assert_close(mean_dropped, deterministic, atol=0.05 * scale, rtol=0.0)


def test_gradcheck_fused_policy(generator: torch.Generator) -> None:
    dtype = torch.float64
    x = torch.randn(7, 3, generator=generator, dtype=dtype, requires_grad=True)
    inverse = (0.5 + torch.rand(3, generator=generator, dtype=dtype)).requires_grad_()
    twice_centres_t = torch.randn(3, 5, generator=generator, dtype=dtype, requires_grad=True)
    offset = torch.randn(5, generator=generator, dtype=dtype, requires_grad=True)
    bits = torch.randint(0, 256, (7, 5), generator=generator, dtype=torch.uint8)
    for actions in (2, 1):  # one action takes its own backward branch
        weights = torch.randn(5, actions, generator=generator, dtype=dtype, requires_grad=True)
        for mask_bits, threshold in ((bits, 64), (None, 0)):
            assert gradcheck(
                lambda *a, b=mask_bits, k=threshold: SquashedRBFFunction.apply(*a, b, k, 3.0),
                (x, inverse, twice_centres_t, offset, weights),
            )


def test_exploration_is_uniform_and_bounded() -> None:
    explore = UniformRandomExploration(u_max=10.0, action_dim=1, rng=np.random.default_rng(0))
    actions = np.array([explore(np.zeros(4), t) for t in range(4000)])
    assert actions.shape == (4000, 1)
    assert np.abs(actions).max() <= 10.0
    assert actions.mean() == pytest.approx(0.0, abs=0.3)
    assert actions.var() == pytest.approx(100.0 / 3.0, rel=0.08)


def test_sum_of_sines_is_bounded_and_band_limited() -> None:
    from mcpilco.policies import SumOfSinesExploration

    dt = 1 / 30
    explore = SumOfSinesExploration(10.0, 2, np.random.default_rng(0), dt, max_frequency_hz=2.0)
    actions = np.array([explore(np.zeros(2), t) for t in range(3000)])  # 100 s
    assert actions.shape == (3000, 2) and np.abs(actions).max() <= 10.0
    spectrum = np.abs(np.fft.rfft(actions, axis=0)) ** 2
    frequencies = np.fft.rfftfreq(3000, dt)
    assert spectrum[frequencies > 2.1].sum() < 0.01 * spectrum.sum()


def test_filtered_noise_has_the_requested_std_and_cutoff() -> None:
    from mcpilco.policies import FilteredNoiseExploration

    dt = 1 / 30
    explore = FilteredNoiseExploration(100.0, 1, np.random.default_rng(0), dt, 1.5, std=2.0)
    actions = np.array([explore(np.zeros(2), t) for t in range(30000)])[:, 0]
    assert actions.std() == pytest.approx(2.0, rel=0.05)
    spectrum = np.abs(np.fft.rfft(actions)) ** 2
    frequencies = np.fft.rfftfreq(actions.size, dt)
    assert spectrum[frequencies > 4.0].sum() < 0.02 * spectrum.sum()


def test_circle_centres_lie_on_the_unit_circle_and_leave_other_columns_alone() -> None:
    columns = [(1, 3)]
    uniform = SquashedRBFPolicy(
        5, 1, 10.0, num_basis=500, generator=torch.Generator().manual_seed(7)
    )
    circle = SquashedRBFPolicy(
        5,
        1,
        10.0,
        num_basis=500,
        angle_centres="circle",
        angle_columns=columns,
        generator=torch.Generator().manual_seed(7),
    )
    c = circle.centres.detach()
    torch.testing.assert_close(c[:, 1] ** 2 + c[:, 3] ** 2, torch.ones(500, dtype=torch.float64))
    angles = torch.atan2(c[:, 1], c[:, 3]).numpy()
    counts, _ = np.histogram(angles, bins=4, range=(-np.pi, np.pi))
    assert counts.min() > 90  # spread round the circle (125 expected per quarter)
    kept = [0, 2, 4]
    torch.testing.assert_close(c[:, kept], uniform.centres.detach()[:, kept])
    torch.testing.assert_close(circle.weights, uniform.weights)


def test_bad_angle_centre_options_name_the_key() -> None:
    with pytest.raises(ConfigError, match="policy.angle_centres"):
        SquashedRBFPolicy(5, 1, 10.0, angle_centres="ring")
    with pytest.raises(ConfigError, match="angle_columns"):
        SquashedRBFPolicy(5, 1, 10.0, angle_centres="circle", angle_columns=[(1, 5)])


def test_per_column_centre_ranges_bound_each_column(generator: torch.Generator) -> None:
    ranges = [3.0, 3.0, 0.1, 0.1]
    policy = SquashedRBFPolicy(4, 1, 1.0, num_basis=500, centre_range=ranges, generator=generator)
    spread = policy.centres.detach().abs().amax(0).numpy()
    # uniform on ±range: the largest of 500 draws lies within 2% of the bound
    np.testing.assert_allclose(spread, ranges, rtol=0.02)
    assert np.all(spread <= ranges)


@pytest.mark.parametrize("bad", [[1.0, 2.0], [1.0, 1.0, 0.0, 1.0], "wide"])
def test_bad_centre_range_names_the_key(bad: object) -> None:
    with pytest.raises(ConfigError, match="policy.centre_range"):
        SquashedRBFPolicy(4, 1, 1.0, centre_range=bad)  # type: ignore[arg-type]


def test_sum_of_sines_with_equal_amplitudes() -> None:
    from mcpilco.policies import SumOfSinesExploration

    rng = np.random.default_rng(0)
    sines = SumOfSinesExploration(10.0, 2, rng, 1 / 30, num_sines=10, equal_amplitudes=True)
    np.testing.assert_allclose(sines.amplitudes, 1.0)  # u_max / 10 each
    peak = max(np.abs(sines(np.zeros(2), k)).max() for k in range(3000))
    assert peak <= 10.0 + 1e-12
