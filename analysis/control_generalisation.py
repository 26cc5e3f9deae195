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
from omegaconf import DictConfig, OmegaConf
from scipy.stats import binomtest

from analysis.control_report import run_dirs, task_of
from analysis.thesis import kernel_label
from mcpilco.run_storage import RunDirectory


def wilson(successes: int, trials: int) -> tuple[float, float]:
    """The Wilson score 95 % interval of a success rate."""
    interval = binomtest(successes, trials).proportion_ci(confidence_level=0.95, method="wilson")
    return float(interval.low), float(interval.high)


def _model_label(config: DictConfig, controller: str) -> str:
    if controller == "TrueModelFL":
        return "—"
    label = (
        f"{kernel_label(OmegaConf.to_container(config.kernel))} "
        f"(`{Path(str(config.model_dir)).name}`)"
    )
    dtype = config.controller.get("prediction_dtype", "float64")
    return label if dtype == "float64" else f"{label}, {dtype}"


def generalisation_table(runs: list[Path]) -> pd.DataFrame:
    """One row per run; ``feasible`` counts the run's references that true-model FL under
    the same limits tracks (from the TrueModelFL run of the same references and initial
    error among ``runs``; NaN without one) and ``feasible_successes`` this run's successes
    on them."""
    rows, feasible_by_task = [], {}
    for run in runs:
        config = OmegaConf.load(run / "config.yaml")
        summary = RunDirectory(run).summary()
        steady = summary[
            [c for c in summary.columns if c.startswith("steady_state_max_error_deg_")]
        ]
        controller = str(config.controller._target_).rsplit(".", 1)[-1]
        low, high = wilson(int(summary["success"].sum()), len(summary))
        saturated = summary.get("saturated_share", pd.Series([0.0] * len(summary)))
        labels = [str(label) for label in summary["reference"]]
        task = (
            str(config.reference._target_),
            tuple(labels),
            float(task_of(config).initial_error),
        )
        succeeded = {
            str(r) for r, ok in zip(summary["reference"], summary["success"], strict=True) if ok
        }
        if controller == "TrueModelFL":
            feasible_by_task[task] = succeeded
        rows.append(
            {
                "family": task[0].rsplit(".", 1)[-1],
                "draws": f"{labels[0]}–{labels[-1]}" if len(labels) > 1 else labels[0],
                "controller": controller,
                "model": _model_label(config, controller),
                "initial_error_rad": task[2],
                "references": len(summary),
                "successes": int(summary["success"].sum()),
                "wilson_low": low,
                "wilson_high": high,
                "diverged": int(summary["diverged"].sum()),
                "saturated_references": int((saturated > 0).sum()),
                "mean_saturated_share": float(saturated.mean()),
                "median_worst_deg": float(steady.max(axis=1).median()),
                "_task": task,
                "_succeeded": succeeded,
            }
        )
    for row in rows:
        feasible = feasible_by_task.get(row["_task"])
        row["feasible"] = float("nan") if feasible is None else len(feasible)
        row["feasible_successes"] = (
            float("nan") if feasible is None else len(feasible & row["_succeeded"])
        )
    return pd.DataFrame(rows).drop(columns=["_task", "_succeeded"])


def generalisation_markdown(table: pd.DataFrame) -> str:
    lines = [
        "| references | draws | controller | model | initial error [rad] | success | "
        "Wilson 95 % | on those true-model FL tracks | diverged | with torque cut (mean share "
        "of steps) | median worst error [deg] |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    order = table.sort_values(["family", "draws", "initial_error_rad", "controller", "model"])
    for row in order.itertuples():
        feasible = (
            "—" if pd.isna(row.feasible) else f"{int(row.feasible_successes)}/{int(row.feasible)}"
        )
        lines.append(
            f"| {row.family} | {row.draws} | {row.controller} | {row.model} | "
            f"{row.initial_error_rad:g} | {row.successes}/{row.references} | "
            f"{row.wilson_low:.2f}–{row.wilson_high:.2f} | {feasible} | {row.diverged} | "
            f"{row.saturated_references} ({100 * row.mean_saturated_share:.1f} %) | "
            f"{row.median_worst_deg:.2f} |"
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
