"""Black-DROPS's CMA-ES search on a toy model with a known optimum, and the calibration
figures on a synthetic case with known coverage."""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import torch
from scipy.stats import norm

from mcpilco.calibration import calibration
from mcpilco.optim.blackdrops import BlackDropsSearch
from mcpilco.optim.rollout import RolloutResult
from mcpilco.policies.rbf import SquashedRBFPolicy

F64 = torch.float64


class ToyRollout:
    """One step x1 = π(x0) from fixed inputs x0 ``[M, 2]``; cost (x1 − π*(x0))², π* a policy
    of the same class: the minimum Ĵ is 0, reached at π* (and wherever π = π* on x0)."""

    horizon = 1

    def __init__(self, policy: SquashedRBFPolicy, target: SquashedRBFPolicy) -> None:
        self.policy = policy
        self.inputs = torch.linspace(-1, 1, 40, dtype=F64)[:, None].repeat(1, 2)
        self.inputs[:, 1] = torch.cos(3 * self.inputs[:, 0])
        with torch.no_grad():
            self.target = target(self.inputs)  # [M, 1]

    def cost(self, states: torch.Tensor) -> torch.Tensor:
        return states[..., 0]  # the "state" is the squared error itself

    def __call__(self, num_particles, dropout, generator, act=None, copies=1):  # noqa: ANN001, ANN204
        assert dropout == 0.0
        actions = act(self.inputs.repeat(copies, 1))  # [P·M, 1]
        error = (actions - self.target.repeat(copies, 1)).square()
        states = torch.stack([torch.zeros_like(error), error])  # [2, P·M, 1]
        return RolloutResult(states.sum(), states.mean((1, 2)), states)


def test_cma_es_minimises_a_known_policy_cost() -> None:
    make = lambda seed: SquashedRBFPolicy(  # noqa: E731
        2,
        1,
        u_max=2.0,
        num_basis=4,
        lengthscale=1.0,
        centre_range=1.0,
        generator=torch.Generator().manual_seed(seed),
    )
    rollout = ToyRollout(make(1), make(2))
    search = BlackDropsSearch(num_particles=40, max_evaluations=6000, sigma=0.3, restarts=1)
    generator = torch.Generator().manual_seed(0)
    start = float(
        search.evaluate(
            rollout,
            torch.nn.utils.parameters_to_vector(rollout.policy.parameters()).detach()[None],
            generator,
        )[0]
    )
    result = search.optimize(rollout, 1, generator)
    final = float(
        search.evaluate(
            rollout,
            torch.nn.utils.parameters_to_vector(rollout.policy.parameters()).detach()[None],
            generator,
        )[0]
    )
    assert start > 0.01
    assert final < 1e-3 * start  # the known minimum is 0
    assert 0 < result.steps  # one trace entry per generation
    assert min(result.signals) == pytest.approx(final, rel=1e-9)  # the best kept


def test_population_rollout_uses_common_random_numbers() -> None:
    """Two identical candidates in one batched evaluation get identical costs."""
    policy = SquashedRBFPolicy(
        2, 1, u_max=2.0, num_basis=4, generator=torch.Generator().manual_seed(3)
    )
    rollout = ToyRollout(policy, policy)
    vector = torch.nn.utils.parameters_to_vector(policy.parameters()).detach()
    costs = BlackDropsSearch(num_particles=40).evaluate(
        rollout, torch.stack([vector, vector + 0.1, vector]), None
    )
    assert costs[0] == costs[2] and costs[1] > costs[0]


@pytest.mark.parametrize("spread", [1.0, 2.0, 0.5])
def test_calibration_of_a_synthetic_case_with_known_coverage(spread: float) -> None:
    """Particles N(0, 1); real states N(0, s²): coverage P(|z| < 1.96/s), Gaussian NLL
    ½ log 2π + s²/2, per component."""
    rng = np.random.default_rng(0)
    steps, count = 4000, 4000
    particles = rng.standard_normal((steps + 1, count, 2))
    real = spread * rng.standard_normal((steps + 1, 2))
    figures = calibration(particles, real, ("p [m]", "θ [rad]"))
    expected_coverage = 2 * norm.cdf(1.959964 / spread) - 1
    expected_nll = 0.5 * math.log(2 * math.pi) + spread**2 / 2
    for name in ("p", "θ"):
        assert figures[f"coverage_{name}"] == pytest.approx(expected_coverage, abs=0.025)
        assert figures[f"nll_{name}"] == pytest.approx(expected_nll, rel=0.05)
    assert figures["coverage_mean"] == pytest.approx(expected_coverage, abs=0.02)


def test_calibration_rejects_mismatched_shapes() -> None:
    with pytest.raises(ValueError, match="components"):
        calibration(np.zeros((5, 10, 3)), np.zeros((5, 2)))
    with pytest.raises(ValueError, match="T' <= T"):
        calibration(np.zeros((5, 10, 2)), np.zeros((6, 2)))


def test_calibration_of_a_rollout_cut_short_uses_its_own_steps() -> None:
    """The ball-and-plate's rollout ends where the ball leaves the plate: the figures are
    those of the particles' first T' steps against it (and NaN with no step at all)."""
    rng = np.random.default_rng(1)
    particles = rng.standard_normal((91, 500, 2))
    real = np.zeros((15, 2))
    real[1:8] = 5.0  # far outside the band at 7 of the 14 compared steps
    figures = calibration(particles, real)
    assert figures["coverage_x0"] == pytest.approx(0.5)
    assert figures == calibration(particles[:15], real)
    empty = calibration(particles, np.zeros((1, 2)))
    assert set(empty) == set(figures) and all(math.isnan(v) for v in empty.values())


def test_report_names_and_calibrates_the_comparison_rows() -> None:
    import pandas as pd

    from analysis.calibration_report import calibration_table, timing_table
    from analysis.thesis import PRECISION, SUCCESS_RATES, configuration_label

    base = {"system": {"_target_": "mcpilco.systems.CartPole"}, "protocol": {"name": "quick"}}
    pilco = {**base, "optimizer": {"_target_": "mcpilco.optim.PilcoSearch"}}
    cma = {**base, "optimizer": {"_target_": "mcpilco.optim.BlackDropsSearch"}}
    assert configuration_label(pilco) == "PILCO [quick]"
    assert configuration_label(cma) == "Black-DROPS [quick]"
    assert SUCCESS_RATES["PILCO"][-1] == 42 and PRECISION["Black-DROPS"][0] == 0.025
    trials = pd.DataFrame(
        {
            "configuration": ["A"] * 4,
            "trial": [0, 1, 1, 1],
            "coverage_mean": [float("nan"), 0.9, 0.5, 0.7],
            "coverage_p": [float("nan"), 1.0, 0.4, 0.8],
            "nll_mean": [float("nan"), 1.0, 3.0, 2.0],
            "fit_seconds": [float("nan"), 1.0, 2.0, 3.0],
            "optimization_seconds": [float("nan"), 10.0, 20.0, 30.0],
        }
    )
    table = calibration_table(trials).iloc[0]
    assert (table["runs"], table["coverage_median"], table["nll_median"]) == (3, 0.7, 2.0)
    assert table["coverage_p_median"] == 0.8
    timing = timing_table(trials).iloc[0]
    assert (timing["fit_seconds"], timing["optimization_seconds"]) == (2.0, 20.0)


def test_building_an_experiment_does_not_load_cma() -> None:
    """cma loads scipy.stats and matplotlib (~1.2 s of every runner's start): only a
    Black-DROPS search that runs imports it."""
    probe = (
        "import sys, mcpilco.build, mcpilco.optim, runners.train_job; "
        "print(sorted(m for m in ('cma', 'matplotlib.pyplot') if m in sys.modules))"
    )
    result = subprocess.run(
        [sys.executable, "-c", probe],
        cwd=Path.cwd(),
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert result.returncode == 0, result.stderr[-2000:]
    assert result.stdout.strip() == "[]"
