"""What a run says while it works: one compact line per finished trial and per phase.

The full row (every figure, full precision) is in ``summary.csv``; the log line keeps what a
person watching the run reads: the evaluation cost and success, the GP data and fit time,
the optimisation's steps and final Ĵ, the calibration, and the trial's wall time.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any


def _number(value: Any) -> float | None:
    try:
        number = float(value)
    except (TypeError, ValueError):
        return None
    return None if math.isnan(number) else number


def trial_line(row: Mapping[str, Any], num_trials: int) -> str:
    """``trial 2/5  cost 15.1 ✓  GP n=60 (kept 60) fit 4.1 s  Ĵ 11.2 after 1234 steps
    (310 s)  coverage 0.91  total 5.3 min`` from a summary row; absent figures are left out."""
    trial = int(row["trial"])
    parts = [f"trial {trial}/{num_trials}" if trial else "trial 0 (exploration)"]
    cost = _number(row.get("eval_cost"))
    if cost is not None:
        success = row.get("success")
        mark = (
            "" if success is None or _number(success) is None else (" ✓" if bool(success) else " ✗")
        )
        parts.append(f"cost {cost:.4g}{mark}")
    env_return = _number(row.get("env_return"))
    if env_return is not None:  # a Gymnasium environment's own return over the trial
        ended = " (ended early)" if bool(row.get("terminated")) else ""
        parts.append(
            f"return {env_return:.4g} in {_number(row.get('env_steps')) or 0:.0f} steps{ended}"
        )
    samples = _number(row.get("gp_samples"))
    if samples is not None:
        kept = _number(row.get("gp_kept"))
        kept_text = f" (kept {kept:.0f})" if kept is not None and kept != samples else ""
        parts.append(
            f"GP n={samples:.0f}{kept_text} fit {_number(row.get('fit_seconds')) or 0:.1f} s"
        )
    steps = _number(row.get("optimization_steps"))
    if steps is not None:
        final = _number(row.get("final_particle_cost"))
        final_text = f"Ĵ {final:.4g} after " if final is not None else ""
        parts.append(
            f"{final_text}{steps:.0f} steps ({_number(row.get('optimization_seconds')) or 0:.0f} s)"
        )
    coverage = _number(row.get("coverage_mean"))
    if coverage is not None:
        parts.append(f"coverage {coverage:.2f}")
    seconds = _number(row.get("trial_seconds"))
    if seconds is not None:
        parts.append(f"{seconds / 60:.1f} min" if seconds >= 60 else f"{seconds:.1f} s")
    return "  ".join(parts)


SUMMARY_COLUMNS = (
    "trial",
    "eval_cost",
    "success",
    "env_return",
    "gp_samples",
    "optimization_steps",
    "final_particle_cost",
    "coverage_mean",
    "trial_seconds",
)
"""The columns of the end-of-run table in the log (all of them are in ``summary.csv``)."""
