"""Regenerate the thesis's tables and plots from the runs of a sweep.

``python -m analysis.report SWEEP_DIR... [--out DIR]`` writes to ``DIR`` (default
``SWEEP_DIR/report``):

* ``success_rates.md`` / ``.csv``: per configuration and trial, the runs whose policy
  succeeded, the rate with its Wilson 95 % interval, and the thesis's rate beside it;
* ``cumulative_cost.png`` / ``.svg``: per configuration, the median and 5–95 percentile band
  of the cumulative evaluation cost (2.17) over the seeds, per trial, with the optimal and
  sub-optimal swing-up costs measured from the sweep's successes (:mod:`analysis.swing_up`);
* ``solved_by_trial.md`` / ``.csv`` and ``first_success.csv``: per configuration and trial,
  the runs solved by that trial among those observed through it (runs that stop at their
  first success and unfinished runs count correctly), per run its first success;
  ``paired.md``: configurations run on the same seeds, which solved first per seed and the
  two-sided sign test (:mod:`analysis.first_success`);
* ``precision.md`` / ``.csv``: Table 2.2 — mean ± std distance from the target over the
  last second of the successful runs at the last trial;
* ``calibration.md`` / ``.csv`` / ``.png``: per trial, the share of real steps inside the
  final policy's particles' 95 % band and the Gaussian NLL (:mod:`analysis.calibration_report`);
* ``timing.md`` / ``.csv``: mean seconds of GP fit and policy search per trial;
* ``prediction_errors.png`` / ``.svg`` / ``.csv``: box plots (Fig. 4.2) and quartiles of the
  absolute one-step prediction errors of each run's last model on its last trial's data
  (:mod:`analysis.prediction_errors`);
* ``index.md``: what is where, the runs that failed, and the command.

A configuration is everything in the resolved config but the seed and the machine settings
(named thesis-style, see :func:`analysis.thesis.configuration_label`, with any other
setting in which runs of one name differ appended: :mod:`analysis.study_tags`); a run
directory is any folder holding a ``config.yaml``.
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import pandas as pd  # noqa: E402

from analysis.calibration_report import (  # noqa: E402
    calibration_figure,
    calibration_markdown,
    calibration_table,
    timing_markdown,
    timing_table,
    with_recomputed,
)
from analysis.first_success import (  # noqa: E402
    first_successes,
    paired_markdown,
    solved_by_trial,
    solved_markdown,
)
from analysis.prediction_errors import prediction_error_figure, prediction_errors  # noqa: E402
from analysis.stats import rate_with_interval, wilson_interval  # noqa: E402
from analysis.sweep import load_sweep  # noqa: E402
from analysis.swing_up import ReferenceCost, reference_costs  # noqa: E402
from analysis.thesis import (  # noqa: E402
    PRECISION,
    SUCCESS_RATES,
    thesis_label,
)

PRECISION_COLUMNS = ("final_position_error", "final_angle_error")
"""What Table 2.2 needs (the cart-pole's final errors)."""


def success_rates(trials: pd.DataFrame) -> pd.DataFrame:
    """Per configuration and learned trial: runs, successes, rate, Wilson interval, thesis."""
    records = []
    learned = trials[trials["trial"] >= 1]
    for (configuration, trial), group in learned.groupby(["configuration", "trial"]):
        successes, total = int(group["success"].sum()), len(group)
        low, high = wilson_interval(successes, total)
        published = SUCCESS_RATES.get(thesis_label(str(configuration)))
        thesis = published[int(trial) - 1] if published and trial <= len(published) else None
        records.append(
            {
                "configuration": configuration,
                "trial": int(trial),
                "runs": total,
                "successes": successes,
                "rate": successes / total,
                "wilson_low": low,
                "wilson_high": high,
                "thesis_rate": None if thesis is None else thesis / 100,
            }
        )
    return pd.DataFrame(records)


def success_markdown(rates: pd.DataFrame) -> str:
    lines = [
        "| configuration | trial | successes | rate [Wilson 95 %] | thesis (50 seeds) |",
        "|---|---|---|---|---|",
    ]
    for row in rates.itertuples():
        thesis = "—" if pd.isna(row.thesis_rate) else f"{100 * row.thesis_rate:.0f} %"
        lines.append(
            f"| {row.configuration} | {row.trial} | {row.successes}/{row.runs} | "
            f"{rate_with_interval(row.rate, row.wilson_low, row.wilson_high)} "
            f"| {thesis} |"
        )
    return "\n".join(lines) + "\n"


def precision(trials: pd.DataFrame) -> pd.DataFrame:
    """Table 2.2 from the successful runs at each configuration's last trial."""
    records = []
    for configuration, group in trials.groupby("configuration"):
        last = group[group["trial"] == group["trial"].max()]
        good = last[last["success"]]
        published = PRECISION.get(thesis_label(str(configuration)))
        records.append(
            {
                "configuration": configuration,
                "trial": int(last["trial"].max()),
                "successful_runs": len(good),
                "position_mean": good["final_position_error"].mean(),
                "position_std": good["final_position_error"].std(ddof=0),
                "angle_mean": good["final_angle_error"].mean(),
                "angle_std": good["final_angle_error"].std(ddof=0),
                "thesis": "—"
                if published is None
                else "{:.3f}±{:.3f} m / {:.3f}±{:.3f} rad".format(*published),
            }
        )
    return pd.DataFrame(records)


def precision_markdown(table: pd.DataFrame) -> str:
    lines = [
        "| configuration | trial | successful runs | position [m] | angle [rad] | thesis |",
        "|---|---|---|---|---|---|",
    ]
    for row in table.itertuples():
        lines.append(
            f"| {row.configuration} | {row.trial} | {row.successful_runs} | "
            f"{row.position_mean:.3f}±{row.position_std:.3f} | "
            f"{row.angle_mean:.3f}±{row.angle_std:.3f} | {row.thesis} |"
        )
    return "\n".join(lines) + "\n"


def cumulative_cost_figure(
    trials: pd.DataFrame, out: Path, references: Sequence[ReferenceCost] = ()
) -> list[Path]:
    """Median and 5–95 percentile band of the cumulative cost per trial, per configuration,
    and a dashed line per reference cost."""
    configurations = sorted(trials["configuration"].unique())
    figure, axes = plt.subplots(
        1, len(configurations), figsize=(4.5 * len(configurations), 3.6), squeeze=False
    )
    for axis, configuration in zip(axes[0], configurations, strict=True):
        group = trials[trials["configuration"] == configuration]
        by_trial = group.groupby("trial")["eval_cost"]
        stats = pd.DataFrame(
            {
                "median": by_trial.median(),
                "low": by_trial.quantile(0.05),
                "high": by_trial.quantile(0.95),
                "runs": by_trial.size(),
            }
        )
        if "success" in group.columns:
            stats["rate"] = group.groupby("trial")["success"].mean()
        axis.fill_between(stats.index, stats["low"], stats["high"], alpha=0.3, label="5–95 %")
        axis.plot(stats.index, stats["median"], "o-", label="median")
        for reference, style in zip(references, ("--", ":"), strict=False):
            axis.axhline(
                reference.cost,
                color="k",
                ls=style,
                lw=1,
                label=f"{reference.name} ({reference.swings} swing{'s' * (reference.swings > 1)})",
            )
        for trial, row in stats.iterrows():
            if trial >= 1 and "rate" in stats.columns:
                axis.annotate(
                    f"{100 * row['rate']:.0f}%", (trial, row["high"]), ha="center", va="bottom"
                )
        axis.set_title(f"{configuration}\n({int(stats['runs'].max())} seeds)", fontsize=8)
        axis.set_xlabel("trial")
        axis.set_ylabel("cumulative cost (2.17)")
        axis.set_xticks(list(stats.index))
        axis.legend(fontsize=7)
    figure.tight_layout()
    paths = [out / "cumulative_cost.png", out / "cumulative_cost.svg"]
    for path in paths:
        figure.savefig(path, dpi=120)
    plt.close(figure)
    return paths


def write_report(paths: Sequence[Path], out: Path, command: str) -> dict[str, Path]:
    """Write every table and figure for the runs under ``paths`` into ``out``."""
    trials, failed = load_sweep(paths)
    if trials.empty:
        raise SystemExit(f"no finished trials under {', '.join(map(str, paths))}")
    out.mkdir(parents=True, exist_ok=True)
    sections, references, figures = [], list[ReferenceCost](), list[Path]()
    if "success" in trials.columns:
        rates = success_rates(trials)
        rates.to_csv(out / "success_rates.csv", index=False)
        (out / "success_rates.md").write_text(success_markdown(rates))
        sections.append("- [success rates per trial](success_rates.md) ([csv](success_rates.csv))")
        runs = first_successes(trials)
        runs.to_csv(out / "first_success.csv", index=False)
        solved = solved_by_trial(runs)
        solved.to_csv(out / "solved_by_trial.csv", index=False)
        (out / "solved_by_trial.md").write_text(solved_markdown(solved))
        sections.append(
            "- [solved by each trial](solved_by_trial.md) ([csv](solved_by_trial.csv), per run: "
            "[first_success.csv](first_success.csv)): runs stopped at their first success or "
            "unfinished count as far as they were observed"
        )
        comparisons = paired_markdown(runs)
        if comparisons:
            (out / "paired.md").write_text("# Paired by seed: which solved first\n\n" + comparisons)
            sections.append(
                "- [configurations paired by seed](paired.md): which solved first, sign test"
            )
        references = reference_costs(trials)
    else:
        sections.append("- no success rates: the system reports no success criterion")
    if "success" in trials.columns and set(PRECISION_COLUMNS) <= set(trials.columns):
        table = precision(trials)
        table.to_csv(out / "precision.csv", index=False)
        (out / "precision.md").write_text(precision_markdown(table))
        sections.append(
            "- [precision at the target, Table 2.2](precision.md) ([csv](precision.csv))"
        )
    else:
        sections.append("- no Table 2.2: the system reports no final position/angle errors")
    if "eval_cost" in trials.columns and trials["eval_cost"].notna().any():
        figures = cumulative_cost_figure(trials, out, references)
    else:
        sections.append("- no cumulative-cost figure: the system reports no evaluation cost")
    trials = with_recomputed(trials)
    if "coverage_mean" in trials.columns and trials["coverage_mean"].notna().any():
        table = calibration_table(trials)
        table.to_csv(out / "calibration.csv", index=False)
        (out / "calibration.md").write_text(calibration_markdown(table))
        figures += calibration_figure(trials, out)
        sections.append(
            "- [model calibration per trial](calibration.md) ([csv](calibration.csv)): real "
            "steps inside the particles' 95 % band, Gaussian NLL"
        )
    if "optimization_seconds" in trials.columns:
        timing = timing_table(trials)
        timing.to_csv(out / "timing.csv", index=False)
        (out / "timing.md").write_text(timing_markdown(timing))
        sections.append("- [seconds per trial: GP fit and policy search](timing.md)")
    errors = prediction_errors(trials)
    if not errors.empty:
        figures += prediction_error_figure(errors, out)
        quartiles = errors.groupby(["configuration", "output"])["error"].describe()
        quartiles.to_csv(out / "prediction_errors.csv")
    runs = trials.groupby("configuration")["run"].nunique()
    index = [
        "# Sweep report",
        "",
        f"Generated by `{command}` from {trials['run'].nunique()} runs.",
        "",
        "| configuration | runs |",
        "|---|---|",
        *[f"| {name} | {count} |" for name, count in runs.items()],
        "",
        *sections,
        *[f"- ![{p.stem}]({p.name})" for p in figures if p.suffix == ".png"],
        "",
        "Reference lines (measured here, analysis/swing_up.py: median cumulative cost of the "
        "successful rollouts by number of pole swings before upright): "
        + (
            "; ".join(
                f"{r.name} = {r.cost:.1f} ({r.swings} swing(s), {r.count} rollouts)"
                for r in references
            )
            or "none (no successful rollouts)"
        ),
        "",
        "Failed runs: " + (", ".join(f"`{p}`" for p in failed) if failed else "none"),
        "",
    ]
    (out / "index.md").write_text("\n".join(index))
    return {"index": out / "index.md"}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("paths", nargs="+", type=Path, help="sweep or run directories")
    parser.add_argument("--out", type=Path, default=None, help="default: FIRST_PATH/report")
    args = parser.parse_args()
    out = args.out or args.paths[0] / "report"
    command = "python -m analysis.report " + " ".join(map(str, args.paths))
    written = write_report(args.paths, out, command)
    print(f"wrote {written['index']}")  # noqa: T201


if __name__ == "__main__":
    main()
