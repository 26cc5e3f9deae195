"""The tables of the results pages, generated from the committed run summaries.

``python -m analysis.results_tables [--check]`` rewrites, in each page under
``docs/results/*.md``, every block between ``<!-- table: NAME -->`` and ``<!-- /table -->``
with what the analysis commands compute from the study folders' ``summary.csv``,
``config.yaml``, ``model.json`` and report CSVs (all kept in the work tree: see
``analysis.study_archive``). ``--check`` writes nothing and exits 1 naming the tables that
differ (the test suite runs it), so a typed or stale number cannot stay on a page.
"""

from __future__ import annotations

import argparse
import re
import sys
from collections.abc import Callable
from pathlib import Path

import pandas as pd

from analysis import (
    cgpdm_leads,
    cgpdm_report,
    control_coverage,
    control_report,
    gym_report,
    report,
    summary,
)
from analysis import control_generalisation as generalisation
from analysis.first_success import first_successes, solved_by_trial, solved_markdown
from analysis.sweep import load_sweep

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "docs" / "results"
BLOCK = re.compile(
    r"(<!-- table: (?P<name>[\w.-]+) -->\n)(?P<body>.*?)(<!-- /table -->)", re.DOTALL
)


def _relative(path: str) -> str:
    try:
        return Path(path).resolve().relative_to(RESULTS).as_posix()
    except ValueError:
        return path


def runs_table(*studies: str, metric: str = "eval_cost", unit: str = "") -> str:
    """One row per training run of the study folders: where, kernel (and budget tag), seed,
    first success, ``metric`` per trial (the evaluation cost by default; ✓ success), wall
    time."""
    table = summary.load_runs([RESULTS / s for s in studies])
    if metric != "eval_cost":
        for index, run in table["run"].items():
            rows = pd.read_csv(Path(run) / "summary.csv").set_index("trial")[metric]
            for trial, value in rows.items():
                table.loc[index, f"cost_T{trial}"] = value
    trials = sorted(int(c.removeprefix("cost_T")) for c in table.columns if c.startswith("cost_T"))
    label = f" {unit}" if unit else ""
    header = [
        "run",
        "kernel",
        "seed",
        "first success",
        *[f"T{t}{label}" for t in trials],
        "wall (min)",
    ]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for row in table.sort_values("run").to_dict("records"):
        costs = []
        for t in trials:
            value = row.get(f"cost_T{t}")
            mark = " ✓" if row.get(f"success_T{t}") is True else ""
            costs.append("—" if value is None or pd.isna(value) else f"{value:.1f}{mark}")
        first = "—" if pd.isna(row["first_success"]) else f"T{int(row['first_success'])}"
        cells = [f"`{_relative(row['run'])}`", str(row["kernel"]), str(row["seed"]), first, *costs]
        lines.append("| " + " | ".join([*cells, f"{row['wall_minutes']:.0f}"]) + " |")
    return "\n".join(lines) + "\n"


def success_table(*studies: str) -> str:
    """Successes per configuration and learned trial beside the thesis's 50-seed rates."""
    trials, _ = load_sweep([RESULTS / s for s in studies])
    return report.success_markdown(report.success_rates(trials))


def solved_table(*studies: str) -> str:
    """Runs stopped at their first success: solved by trial k per configuration."""
    trials, _ = load_sweep([RESULTS / s for s in studies])
    return solved_markdown(solved_by_trial(first_successes(trials)))


def median_cost_table(*paths: str) -> str:
    """Per configuration: runs, successes over all learned trials, median evaluation cost per
    trial and the lowest cost of any trial (the comparison of algorithms, Fig. 2.8)."""
    trials, _ = load_sweep([RESULTS / p for p in paths])
    numbers = sorted(int(t) for t in trials["trial"].unique())
    header = ["configuration", "runs", "successes", *[f"median T{t}" for t in numbers], "lowest"]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for configuration, group in trials.groupby("configuration"):
        medians = group.groupby("trial")["eval_cost"].median()
        learned = group[group["trial"] >= 1]
        cells = [
            str(configuration),
            str(group["run"].nunique()),
            f"{int(learned['success'].sum())}/{len(learned)}",
        ]
        cells += [f"{medians[t]:.1f}" if t in medians else "—" for t in numbers]
        lines.append("| " + " | ".join([*cells, f"{learned['eval_cost'].min():.1f}"]) + " |")
    return "\n".join(lines) + "\n"


def control_nmse() -> str:
    folder = RESULTS / "control" / "models"
    models = control_report.model_table([folder / "se", folder / "gip"])
    models["model"] = [_relative(m) for m in models["model"]]
    return control_report.nmse_markdown(models)


def control_tracking() -> str:
    runs = control_report.run_dirs([RESULTS / "control" / "experiments"])
    return control_report.tracking_markdown(control_report.tracking_table(runs))


def control_tracking_limits() -> str:
    runs = control_report.run_dirs([RESULTS / "control" / "experiments_torque_limits"])
    return control_report.tracking_markdown(control_report.tracking_table(runs))


LATENCY_LINE = re.compile(
    r"^\s+(?P<controller>\w+)(?: \((?P<kernel>\w+), n=(?P<n>\d+), (?P<dtype>\w+)\))?\s+"
    r"median\s+(?P<median>[\d.]+) ms\s+p99\s+(?P<p99>[\d.]+) ms$"
)


def control_latency() -> str:
    """The controllers' latency per call from a committed ``runners.bench_control`` output:
    one row per controller and kernel, one column per prediction precision."""
    text = (RESULTS / "control" / "latency" / "2026-12-07_fitted_models.txt").read_text()
    cells: dict[tuple[str, str], dict[str, str]] = {}
    for line in text.splitlines():
        match = LATENCY_LINE.match(line)
        if match:
            kernel = match["kernel"] or "—"
            dtype = match["dtype"] or "float64"
            label = f"{float(match['median']):.3f} / {float(match['p99']):.3f}"
            cells.setdefault((match["controller"], kernel), {})[dtype] = label
    lines = [
        "| controller | kernel | float64 median / p99 [ms] | float32 median / p99 [ms] |",
        "|---|---|---|---|",
    ]
    for (controller, kernel), by_dtype in cells.items():
        lines.append(
            f"| {controller} | {kernel} | {by_dtype.get('float64', '—')} | "
            f"{by_dtype.get('float32', '—')} |"
        )
    return "\n".join(lines) + "\n"


def control_generalisation() -> str:
    runs = control_report.run_dirs([RESULTS / "control" / "generalisation"])
    table = generalisation.generalisation_table(runs)
    return generalisation.generalisation_markdown(table)


def control_coverage_table() -> str:
    rows = pd.read_csv(RESULTS / "control" / "generalisation" / "coverage.csv")
    return control_coverage.coverage_markdown(rows)


def cgpdm_table(study: str) -> str:
    """The Fig. 6.5 table of a CGPDM study from its committed ``report/models.csv``."""
    models = pd.read_csv(RESULTS / study / "report" / "models.csv")
    return cgpdm_report.markdown(cgpdm_report.cells(models))


def gym_tables(
    study: str, trial: int, target: float
) -> tuple[Callable[[], str], Callable[[], str]]:
    """A Gymnasium study's tables: env_return per trial over seeds, and trial ``trial``'s
    policies on fresh episodes (each run's ``evaluation/trial_KK.json``) against ``target``."""
    folder = RESULTS / study
    return (
        lambda: gym_report.returns_markdown(gym_report.load_summaries(folder)),
        lambda: gym_report.evaluation_markdown(
            gym_report.load_evaluations(folder, trial), trial, target
        ),
    )


GYM_PENDULUM = gym_tables("gym_pendulum", 10, -200.0)  # issue 58's target
GYM_PENDULUM_TRUE = gym_tables("gym_pendulum_true_dynamics", 10, -200.0)  # the diagnosis
GYM_INVERTED_PENDULUM = gym_tables("gym_inverted_pendulum", 5, 1000.0)  # the maximum

TABLES: dict[str, Callable[[], str]] = {
    "thesis_settings": lambda: runs_table("cartpole_thesis_settings"),
    "kernel_ablation_quick": lambda: success_table("kernel_ablation_quick/sweep"),
    "comparison_quick": lambda: report.success_markdown(
        pd.read_csv(RESULTS / "comparison_quick" / "report" / "success_rates.csv")
    ),
    "kernel_ablation_quick_costs": lambda: median_cost_table("kernel_ablation_quick/sweep"),
    "float64_recheck": lambda: solved_table("mixed_precision/recheck_2026-12-05"),
    "furuta_pms_thesis": lambda: runs_table("furuta_pms_thesis"),
    "furuta_df_thesis": lambda: runs_table("furuta_df_thesis"),
    "ball_and_plate_df": lambda: runs_table("ball_and_plate_df"),
    "ur5_m200": lambda: runs_table("ur5_m200", metric="mean_error_mm", unit="(mm)"),
    "ur5_df": lambda: runs_table("ur5_df", metric="mean_error_mm", unit="(mm)"),
    "control_nmse": control_nmse,
    "control_tracking": control_tracking,
    "control_tracking_limits": control_tracking_limits,
    "control_generalisation": control_generalisation,
    "control_latency": control_latency,
    "control_coverage": control_coverage_table,
    "cgpdm_errors": lambda: cgpdm_table("cgpdm"),
    "cgpdm_external_leads": lambda: cgpdm_table("cgpdm_external"),  # issue 57's leads
    "cgpdm_external_defaults": lambda: cgpdm_leads.markdown(
        pd.read_csv(RESULTS / "cgpdm_external" / "report" / "leads.csv")
    ),
    "gym_pendulum_returns": GYM_PENDULUM[0],
    "gym_pendulum_evaluation": GYM_PENDULUM[1],
    "gym_pendulum_true_dynamics_evaluation": GYM_PENDULUM_TRUE[1],
    "gym_inverted_pendulum_returns": GYM_INVERTED_PENDULUM[0],
    "gym_inverted_pendulum_evaluation": GYM_INVERTED_PENDULUM[1],
}
"""Every table a results page may hold, by the name its marker gives."""


def render(page: Path, cache: dict[str, str]) -> tuple[str, list[str]]:
    """The page with its tables regenerated, and the names of those that changed."""
    text = page.read_text()
    changed: list[str] = []

    def replace(match: re.Match[str]) -> str:
        name = match["name"]
        if name not in TABLES:
            raise KeyError(
                f"{page}: <!-- table: {name} --> names no table (known: {', '.join(TABLES)})"
            )
        if name not in cache:
            cache[name] = TABLES[name]()
        if match["body"] != cache[name]:
            changed.append(name)
        return match.group(1) + cache[name] + match.group(4)

    return BLOCK.sub(replace, text), changed


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument(
        "--check", action="store_true", help="write nothing; exit 1 on a difference"
    )
    args = parser.parse_args(argv)
    cache: dict[str, str] = {}
    stale = []
    for page in sorted(RESULTS.glob("*.md")):
        text, changed = render(page, cache)
        if changed:
            stale += [f"{page.relative_to(ROOT)}: {name}" for name in changed]
            if not args.check:
                page.write_text(text)
    if args.check and stale:
        sys.stderr.write(
            "results tables differ from the committed summaries: " + "; ".join(stale) + "\n"
        )
        sys.stderr.write("(python -m analysis.results_tables rewrites them)\n")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
