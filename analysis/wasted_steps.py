"""How many policy-optimisation steps came after the final cost was reached:
``python -m analysis.wasted_steps RUN_DIR... [--csv OUT] [--tolerance 0.01]``.

Reads every ``optimization/trial_KK.csv`` under the given run directories (the Ĵ trace per
step that each run stores) and prints, per trial, N_opt (steps run), the step after which
Ĵ stayed within the tolerance of the Ĵ the optimisation ended with
(:func:`mcpilco.optim.convergence.steps_to_final`), the share of steps after it, and the
steps at which the monitoring schedule lowered p_d and α_lr (eq. 2.14). A Markdown summary
over all trials follows.
"""

from __future__ import annotations

import argparse
from collections.abc import Iterable
from pathlib import Path

import pandas as pd

from mcpilco.optim.convergence import steps_to_final


def trial_rows(run: Path, tolerance: float) -> list[dict[str, object]]:
    """One record per optimisation trace of one run directory."""
    rows = []
    for trace_file in sorted((run / "optimization").glob("trial_*.csv")):
        trace = pd.read_csv(trace_file)
        if trace.empty:
            continue
        reached = steps_to_final(trace["cost"].tolist(), tolerance)
        steps = len(trace)
        reductions = trace.index[trace["learning_rate"].diff().fillna(0.0) < 0].tolist()
        rows.append(
            {
                "run": str(run),
                "trial": int(trace_file.stem.removeprefix("trial_")),
                "steps": steps,
                "steps_to_final": reached,
                "after_share": None if reached is None else (steps - reached) / steps,
                "final_cost": float(trace["cost"].tail(20).mean()),
                "reductions_at": " ".join(str(r) for r in reductions),
            }
        )
    return rows


def load(paths: Iterable[Path], tolerance: float) -> pd.DataFrame:
    """Every run directory (one holding ``optimization/``) under the given paths."""
    runs = sorted({p.parent for path in paths for p in Path(path).rglob("optimization")})
    return pd.DataFrame([row for run in runs for row in trial_rows(run, tolerance)])


def markdown(table: pd.DataFrame) -> str:
    """Totals over all traces: steps run, steps after the final cost was reached."""
    total = int(table["steps"].sum())
    after = int((table["steps"] - table["steps_to_final"]).sum())
    share = table["after_share"]
    return "\n".join(
        [
            "| traces | steps run | after Ĵ_final was reached | share per trace: median "
            "(min–max) |",
            "|---|---|---|---|",
            f"| {len(table)} | {total} | {after} ({100 * after / total:.0f} %) | "
            f"{100 * share.median():.0f} % ({100 * share.min():.0f}–{100 * share.max():.0f} %) |",
        ]
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("runs", nargs="+", type=Path, help="run directories or folders of them")
    parser.add_argument("--tolerance", type=float, default=0.01, help="relative to Ĵ_final")
    parser.add_argument("--csv", type=Path, help="write the per-trial table here")
    args = parser.parse_args()
    table = load(args.runs, args.tolerance)
    if table.empty:
        raise SystemExit(f"no optimisation traces under {[str(p) for p in args.runs]}")
    with pd.option_context("display.width", 200, "display.max_rows", 500):
        print(table.drop(columns="run").to_string(index=False))  # noqa: T201
    print(markdown(table))  # noqa: T201
    if args.csv:
        table.to_csv(args.csv, index=False)


if __name__ == "__main__":
    main()
