"""The monitoring signal that schedules dropout and learning rate (thesis eq. 2.12–2.15)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from mcpilco.errors import ConfigError


@dataclass(frozen=True)
class ScheduleEvent:
    """What one update decided: ``reduced`` p_d/α_lr/σ_s (2.14), ``stop`` (2.15 false)."""

    signal: float
    reduced: bool
    stop: bool


@dataclass
class MonitoringSchedule:
    """EMA statistics of the cost change ΔĴ and the filtered ratio s (eq. 2.12).

    When |s| < σ_s for ``window`` consecutive steps (2.13): p_d −= Δp_d, α_lr *= λ_s,
    σ_s *= λ_s (floored at ``threshold_min``) and the window restarts (2.14). The
    optimisation stops when p_d < 0 or α_lr < α_lr_min (2.15 false). Defaults: Table 2.1.

    The three EMAs start at 0, so for the first ~1/(1 − α_s) steps s is pulled towards 0
    and |s| < σ_s counts towards a reduction before the cost has had time to move.
    ``bias_correction=True`` (not in the thesis; off by default) divides each EMA by
    1 − α_s^t after t cost changes, as Adam does its moments: the mean and variance of ΔĴ
    and s become weighted averages of what was seen, ŝ_1 = sign(ΔĴ_1)/√α_s, and the
    correction fades as t grows (1 − α_s^300 = 0.95 for α_s = 0.99).

    Attributes:
        dropout: p_d. dropout_step: Δp_d. learning_rate: α_lr. learning_rate_min: α_lr_min.
        ema: α_s. threshold: σ_s. threshold_min: floor of σ_s. window: n_s. factor: λ_s.
        bias_correction: divide the EMAs by 1 − α_s^t (see above).
        signal: s after the last update (corrected when ``bias_correction``), the value
            compared with σ_s.
    """

    dropout: float = 0.25
    dropout_step: float = 0.125
    learning_rate: float = 0.01
    learning_rate_min: float = 0.0025
    ema: float = 0.99
    threshold: float = 0.08
    threshold_min: float = 0.01
    window: int = 200
    factor: float = 0.5
    bias_correction: bool = False
    signal: float = field(default=0.0, init=False)
    raw_signal: float = field(default=0.0, init=False)
    changes_seen: int = field(default=0, init=False)
    mean_change: float = field(default=0.0, init=False)
    variance_change: float = field(default=0.0, init=False)
    steps_below: int = field(default=0, init=False)
    previous_cost: float | None = field(default=None, init=False)

    def __post_init__(self) -> None:
        checks = {
            "dropout": 0.0 <= self.dropout < 1.0,
            "dropout_step": self.dropout_step >= 0.0,
            "learning_rate": self.learning_rate > 0.0,
            "learning_rate_min": self.learning_rate_min > 0.0,
            "ema": 0.0 <= self.ema < 1.0,
            "threshold": self.threshold > 0.0,
            "window": self.window >= 1,
            "factor": 0.0 < self.factor < 1.0,
        }
        for key, ok in checks.items():
            if not ok:
                raise ConfigError(
                    f"optimizer.schedule.{key} is out of range: {getattr(self, key)!r}"
                )
        if not isinstance(self.bias_correction, bool):
            raise ConfigError(
                "optimizer.schedule.bias_correction must be true or false, "
                f"got {self.bias_correction!r}"
            )

    def update(self, cost: float) -> ScheduleEvent:
        """Feed Ĵ(θ_j); returns the decision taken after step j."""
        if self.previous_cost is None:
            self.previous_cost = cost
            return ScheduleEvent(self.signal, reduced=False, stop=False)
        change = cost - self.previous_cost
        self.previous_cost = cost
        a = self.ema
        previous_mean = self.mean_change
        self.mean_change = a * previous_mean + (1.0 - a) * change
        self.variance_change = a * (
            self.variance_change + (1.0 - a) * (change - previous_mean) ** 2
        )
        self.changes_seen += 1
        unbias = 1.0 - a**self.changes_seen if self.bias_correction else 1.0
        # mean/√variance: the same 1/unbias divides both moments.
        ratio = (
            self.mean_change / math.sqrt(self.variance_change * unbias)
            if self.variance_change > 0
            else 0.0
        )
        self.raw_signal = a * self.raw_signal + (1.0 - a) * ratio
        self.signal = self.raw_signal / unbias
        self.steps_below = self.steps_below + 1 if abs(self.signal) < self.threshold else 0
        reduced = self.steps_below >= self.window
        if reduced:
            self.dropout -= self.dropout_step
            self.learning_rate *= self.factor
            self.threshold = max(self.threshold * self.factor, self.threshold_min)
            self.steps_below = 0
        stop = self.dropout < 0.0 or self.learning_rate < self.learning_rate_min
        return ScheduleEvent(self.signal, reduced=reduced, stop=stop)
