"""Monitoring-signal schedule against a direct transcription of eq. 2.12–2.15."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mcpilco.errors import ConfigError
from mcpilco.optim import MonitoringSchedule


def reference_signal(costs: list[float], ema: float) -> list[float]:
    """s_j of eq. 2.12 computed from its definition, one list per step j ≥ 1."""
    mean = variance = signal = 0.0
    signals = []
    for previous, current in zip(costs[:-1], costs[1:], strict=True):
        change = current - previous
        new_mean = ema * mean + (1 - ema) * change
        variance = ema * (variance + (1 - ema) * (change - mean) ** 2)
        mean = new_mean
        ratio = mean / math.sqrt(variance) if variance > 0 else 0.0
        signal = ema * signal + (1 - ema) * ratio
        signals.append(signal)
    return signals


def test_signal_follows_equation_2_12() -> None:
    rng = np.random.default_rng(0)
    costs = list(50 * np.exp(-np.arange(300) / 80) + rng.normal(0, 0.3, 300))
    schedule = MonitoringSchedule(window=10_000)
    got = [schedule.update(c).signal for c in costs][1:]
    np.testing.assert_allclose(got, reference_signal(costs, 0.99), rtol=1e-12, atol=1e-15)


def test_flat_cost_reduces_every_window_and_stops_when_dropout_negative() -> None:
    schedule = MonitoringSchedule(window=50)
    events = []
    while not (events and events[-1].stop):
        events.append(schedule.update(10.0))
    reductions = [j for j, e in enumerate(events) if e.reduced]
    stop = len(events) - 1
    # j = 0 only stores the cost; |s| = 0 < σ_s from j = 1 on: reductions at 50, 100, 150.
    assert reductions[:3] == [50, 100, 150]
    assert stop == 150  # third reduction: p_d = 0.25 - 3 * 0.125 < 0 (2.15 false)
    assert schedule.learning_rate == pytest.approx(0.01 * 0.5**3)
    assert schedule.threshold == pytest.approx(0.01)  # 0.08 → 0.04 → 0.02 → floor 0.01


def test_steady_descent_never_reduces() -> None:
    schedule = MonitoringSchedule(window=50)
    events = [schedule.update(100.0 - 0.1 * j) for j in range(500)]
    assert not any(e.reduced for e in events)
    assert events[-1].signal < -0.5


def test_without_dropout_stops_on_learning_rate() -> None:
    schedule = MonitoringSchedule(dropout=0.0, dropout_step=0.0, window=20)
    events = [schedule.update(1.0) for _ in range(200)]
    stop = next(j for j, e in enumerate(events) if e.stop)
    assert [j for j, e in enumerate(events[: stop + 1]) if e.reduced] == [20, 40, 60]
    assert stop == 60  # 0.01 → 0.005 → 0.0025 → 0.00125 < α_lr_min


@pytest.mark.parametrize("key,value", [("window", 0), ("factor", 1.5), ("learning_rate", -1.0)])
def test_bad_values_name_the_key(key: str, value: float) -> None:
    with pytest.raises(ConfigError, match=f"optimizer.schedule.{key}"):
        MonitoringSchedule(**{key: value})


def weighted_average(values: list[float], ema: float) -> float:
    """Σ α^(t−i) v_i / Σ α^(t−i): the EMA of ``values`` with its zero start divided out."""
    weights = ema ** np.arange(len(values) - 1, -1, -1)
    return float(np.dot(weights, values) / weights.sum())


def test_bias_corrected_signal_is_the_weighted_average_of_the_ratios() -> None:
    rng = np.random.default_rng(1)
    costs = list(50 * np.exp(-np.arange(400) / 80) + rng.normal(0, 0.3, 400))
    ema = 0.99
    schedule = MonitoringSchedule(window=10_000, ema=ema, bias_correction=True)
    got = [schedule.update(c).signal for c in costs][1:]
    changes = np.diff(costs)
    ratios, mean, variance = [], 0.0, 0.0
    for t, change in enumerate(changes, start=1):
        # Corrected moments from their definitions: the weighted mean of the changes and
        # the zero-started variance recursion divided by 1 − α^t.
        variance = ema * (variance + (1 - ema) * (change - mean) ** 2)
        mean = ema * mean + (1 - ema) * change
        assert mean / (1 - ema**t) == pytest.approx(weighted_average(list(changes[:t]), ema))
        ratios.append(weighted_average(list(changes[:t]), ema) / math.sqrt(variance / (1 - ema**t)))
    expected = [weighted_average(ratios[:t], ema) for t in range(1, len(ratios) + 1)]
    np.testing.assert_allclose(got, expected, rtol=1e-9)


def test_bias_corrected_first_signal_is_the_sign_of_the_change_over_root_ema() -> None:
    schedule = MonitoringSchedule(ema=0.99, bias_correction=True)
    schedule.update(10.0)
    assert schedule.update(9.0).signal == pytest.approx(-1 / math.sqrt(0.99), rel=1e-12)
    plain = MonitoringSchedule(ema=0.99)
    plain.update(10.0)
    # Without the correction: ratio (0.01·c)/√(0.99·0.01·c²) = 0.1/√0.99, then × (1 − α).
    assert plain.update(9.0).signal == pytest.approx(-0.001 / math.sqrt(0.99), rel=1e-12)


def test_bias_correction_removes_the_warm_up_reduction_of_a_falling_noisy_cost() -> None:
    # Ĵ falls by 0.02 per step under noise of std 0.1: the ratio mean/std of the changes is
    # about −0.14, above σ_s = 0.08 in size. Zero-started, s needs ~50 steps to reach it;
    # with a short window the plain schedule reduces during that warm-up, the corrected one
    # never does.
    rng = np.random.default_rng(2)
    costs = list(100 - 0.02 * np.arange(600) + rng.normal(0, 0.1, 600))
    plain = MonitoringSchedule(window=20)
    corrected = MonitoringSchedule(window=20, bias_correction=True)
    plain_reductions = [j for j, c in enumerate(costs) if plain.update(c).reduced]
    corrected_reductions = [j for j, c in enumerate(costs) if corrected.update(c).reduced]
    assert plain_reductions and plain_reductions[0] == 20
    assert corrected_reductions == []


def test_bias_correction_must_be_a_bool() -> None:
    with pytest.raises(ConfigError, match="optimizer.schedule.bias_correction"):
        MonitoringSchedule(bias_correction="yes")  # type: ignore[arg-type]
