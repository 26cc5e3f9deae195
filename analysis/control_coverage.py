"""Does a tracking error come from leaving the training data? (issue 56's diagnosis)

    python -m analysis.control_coverage RUN_DIR_OR_SWEEP... [--out FILE.md] [--csv FILE.csv]

For each control run directory: its references are rebuilt from the run's config (targets
checked first; nothing else in the directory executes) and sampled at 1 kHz; the training
inputs of the run's GP model (``model_dir/gp.pt``, read as tensors) give a per-joint range
[min, max] of q, q̇ and q̈. One row per reference: the share of the steady-state part
(t ≥ settle) in which some joint's reference position, velocity or acceleration lies outside
that range, the first time the velocity leaves it, and the run's worst steady-state error.
Per run, Spearman's rank correlation between the velocity share and the error.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import pandas as pd
from scipy.stats import spearmanr

from analysis.control_report import run_dirs, task_of
from mcpilco.build import make
from mcpilco.control.reference_families import ReferenceFamily
from mcpilco.run_storage import RunDirectory, load_tensors
from mcpilco.safe_config import load_run_config

QUANTITIES = ("q", "qd", "qdd")


def training_ranges(model_dir: Path, num_joints: int) -> dict[str, np.ndarray]:
    """Per quantity, ``[2, n]`` (min, max) over the model's training inputs, in rad, rad/s,
    rad/s² (the stored inputs are divided by ``input_scale``; multiplied back here)."""
    state = load_tensors(model_dir / "gp.pt")
    inputs = (state["gp.train_inputs"] * state["input_scale"]).numpy()  # [N, 3n]
    return {
        name: np.stack([block.min(0), block.max(0)])
        for name, block in zip(QUANTITIES, np.split(inputs, 3, axis=1), strict=True)
        if block.shape[1] == num_joints
    }


def coverage_rows(run: Path) -> list[dict[str, object]]:
    config = load_run_config(run)
    family: ReferenceFamily = make(config.reference)
    num_joints = int(config.robot.num_joints)
    references = family.references(num_joints)
    ranges = training_ranges(Path(str(config.model_dir)), num_joints)
    summary = RunDirectory(run).summary().set_index("reference")
    steady = summary[[c for c in summary.columns if c.startswith("steady_state_max_error_deg_")]]
    settle = float(task_of(config).settle)
    rows = []
    for reference in references:
        time = np.arange(0.0, reference.duration, 1e-3)
        values = dict(zip(QUANTITIES, reference(time), strict=True))  # each [T, n]
        late = time >= settle
        row: dict[str, object] = {"run": "/".join(run.parts[-4:]), "reference": reference.label}
        for name, (low, high) in ranges.items():
            outside = ((values[name] < low) | (values[name] > high)).any(axis=1)
            row[f"outside_{name}"] = float(outside[late].mean())
            if name == "qd":
                row["first_exit_s"] = float(time[outside][0]) if outside.any() else float("nan")
        row["worst_deg"] = float(steady.loc[reference.label].max())
        rows.append(row)
    return rows


def coverage_markdown(table: pd.DataFrame) -> str:
    lines = [
        "| run | reference | steady state outside the training range: q / q̇ / q̈ | "
        "q̇ leaves it at [s] | worst error [deg] |",
        "|---|---|---|---|---|",
    ]
    for row in table.itertuples():
        exit_time = "—" if np.isnan(row.first_exit_s) else f"{row.first_exit_s:.2f}"
        lines.append(
            f"| {row.run} | {row.reference} | {100 * row.outside_q:.0f} % / "
            f"{100 * row.outside_qd:.0f} % / {100 * row.outside_qdd:.0f} % | {exit_time} | "
            f"{row.worst_deg:.2f} |"
        )
    lines.append("")
    for run, rows in table.groupby("run", sort=False):
        rho = spearmanr(rows["outside_qd"], rows["worst_deg"])
        lines.append(
            f"- `{run}`: Spearman rank correlation of the velocity share with the worst "
            f"error {rho.statistic:.2f} (p = {rho.pvalue:.3f}, {len(rows)} references)."
        )
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("runs", nargs="+", type=Path, help="control run directories or sweeps")
    parser.add_argument("--out", type=Path, default=None, help="write the table here")
    parser.add_argument("--csv", type=Path, default=None, help="and the rows as CSV here")
    args = parser.parse_args()
    table = pd.DataFrame([row for run in run_dirs(args.runs) for row in coverage_rows(run)])
    if args.csv is not None:
        table.to_csv(args.csv, index=False)
    text = coverage_markdown(table)
    if args.out is None:
        print(text, end="")  # noqa: T201
    else:
        args.out.write_text(text)


if __name__ == "__main__":
    main()
