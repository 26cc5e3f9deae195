"""Success of the torque controllers on references never used in development, per
reference family, with Wilson 95 % intervals (issue 56).

    python -m analysis.control_generalisation RUN_DIR_OR_SWEEP... [--out FILE.md]

One row per control run directory: the family (the ``reference`` group's class), the
controller, the GP model (kernel and model directory), the initial error, successes over
the run's references with the Wilson score interval, diverged runs, how many references
met the torque limits (and the mean share of steps cut), and the median over references
of the worst steady-state joint error. Nothing is instantiated: configs are read as data.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import pandas as pd
from omegaconf import OmegaConf
from scipy.stats import binomtest

from analysis.control_report import run_dirs, task_of
from analysis.thesis import kernel_label
from mcpilco.run_storage import RunDirectory


def wilson(successes: int, trials: int) -> tuple[float, float]:
    """The Wilson score 95 % interval of a success rate."""
    interval = binomtest(successes, trials).proportion_ci(confidence_level=0.95, method="wilson")
    return float(interval.low), float(interval.high)


def generalisation_table(runs: list[Path]) -> pd.DataFrame:
    rows = []
    for run in runs:
        config = OmegaConf.load(run / "config.yaml")
        summary = RunDirectory(run).summary()
        steady = summary[
            [c for c in summary.columns if c.startswith("steady_state_max_error_deg_")]
        ]
        controller = str(config.controller._target_).rsplit(".", 1)[-1]
        low, high = wilson(int(summary["success"].sum()), len(summary))
        saturated = summary.get("saturated_share", pd.Series([0.0] * len(summary)))
        rows.append(
            {
                "family": str(config.reference._target_).rsplit(".", 1)[-1],
                "controller": controller,
                "model": "—"
                if controller == "TrueModelFL"
                else f"{kernel_label(OmegaConf.to_container(config.kernel))} "
                f"(`{Path(str(config.model_dir)).name}`)",
                "initial_error_rad": float(task_of(config).initial_error),
                "references": len(summary),
                "successes": int(summary["success"].sum()),
                "wilson_low": low,
                "wilson_high": high,
                "diverged": int(summary["diverged"].sum()),
                "saturated_references": int((saturated > 0).sum()),
                "mean_saturated_share": float(saturated.mean()),
                "median_worst_deg": float(steady.max(axis=1).median()),
            }
        )
    return pd.DataFrame(rows)


def generalisation_markdown(table: pd.DataFrame) -> str:
    lines = [
        "| references | controller | model | initial error [rad] | success | Wilson 95 % | "
        "diverged | met the torque limits (mean share of steps) | median worst error [deg] |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    order = table.sort_values(["family", "initial_error_rad", "controller", "model"])
    for row in order.itertuples():
        lines.append(
            f"| {row.family} | {row.controller} | {row.model} | {row.initial_error_rad:g} | "
            f"{row.successes}/{row.references} | {row.wilson_low:.2f}–{row.wilson_high:.2f} | "
            f"{row.diverged} | {row.saturated_references} ({100 * row.mean_saturated_share:.1f} %) "
            f"| {row.median_worst_deg:.2f} |"
        )
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("runs", nargs="+", type=Path, help="control run directories or sweeps")
    parser.add_argument("--out", type=Path, default=None, help="write the table here")
    args = parser.parse_args()
    text = generalisation_markdown(generalisation_table(run_dirs(args.runs)))
    if args.out is None:
        print(text, end="")  # noqa: T201
    else:
        args.out.write_text(text)


if __name__ == "__main__":
    main()
