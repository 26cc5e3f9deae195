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
    with pytest.raises(ConfigError, match=f"optimizer.{key}"):
        MonitoringSchedule(**{key: value})
