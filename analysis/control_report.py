"""Tables and figures of the torque-control study (thesis Figs. 5.3–5.6) from its runs.

    python -m analysis.control_report MODEL_DIR... --runs RUN_DIR_OR_SWEEP... [--out DIR]

Writes ``nmse.md`` (test nMSE % per joint of each model directory beside the thesis's),
``test_errors.png/.svg`` (box plots of the absolute test errors per joint, Fig. 5.3),
``tracking.md`` (per run: kernel, controller, initial error, successes over the reference
seeds, worst steady-state error per joint in degrees, controller latency) and, with
``--figure-seed K``, per run ``tracking_<parent>_<run>_seed_KK.png/.svg`` (joint angles against the
reference, torques and tracking errors, Figs. 5.4–5.6). Nothing is instantiated: configs
are read as data.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
from omegaconf import DictConfig, OmegaConf  # noqa: E402

from analysis.thesis import INVERSE_DYNAMICS_NMSE, kernel_label  # noqa: E402
from mcpilco.run_contract import CONTROL, find_runs  # noqa: E402
from mcpilco.run_storage import RunDirectory  # noqa: E402


def model_table(model_dirs: list[Path]) -> pd.DataFrame:
    """One row per model directory: kernel label, fit cost, nMSE % per joint."""
    rows = []
    for directory in model_dirs:
        meta = json.loads((directory / "model.json").read_text())
        label = kernel_label(meta["kernel"])
        rows.append(
            {
                "model": str(directory),
                "kernel": label,
                "fit_points": meta["fit"]["fit_points"],
                "posterior_points": meta["fit"]["posterior_points"],
                "ml2_seconds": meta["fit"]["hyperparameter_seconds"],
                "posterior_seconds": meta["fit"]["posterior_seconds"],
                **{f"nmse_{j + 1}": v for j, v in enumerate(meta["nmse_percent"])},
            }
        )
    return pd.DataFrame(rows)


def nmse_markdown(table: pd.DataFrame) -> str:
    joints = sorted(int(c.split("_")[1]) for c in table.columns if c.startswith("nmse_"))
    header = "| kernel | source | " + " | ".join(f"joint {j}" for j in joints) + " |"
    lines = [header, "|---|---|" + "---|" * len(joints)]
    for row in table.itertuples():
        values = " | ".join(f"{getattr(row, f'nmse_{j}'):.2f}" for j in joints)
        lines.append(f"| {row.kernel} | ours (`{row.model}`) | {values} |")
        thesis = INVERSE_DYNAMICS_NMSE.get(str(row.kernel))
        if thesis:
            lines.append(
                f"| {row.kernel} | thesis | " + " | ".join(f"{v:.2f}" for v in thesis) + " |"
            )
    return "\n".join(lines) + "\n"


def error_boxplots(model_dirs: list[Path], labels: list[str], out: Path) -> None:
    """|f̂ − τ| on the test set per joint, one box per model (Fig. 5.3)."""
    errors = []
    for directory in model_dirs:
        with np.load(directory / "test_predictions.npz") as arrays:
            errors.append(np.abs(arrays["predicted"] - arrays["measured"]))
    joints = errors[0].shape[1]
    figure, axes = plt.subplots(1, joints, figsize=(2.2 * joints, 3.2))
    for j, axis in enumerate(axes):
        axis.boxplot([e[:, j] for e in errors], showfliers=False)
        axis.set_xticks(range(1, len(labels) + 1), labels, fontsize=8)
        axis.set_title(f"joint {j + 1}")
        axis.set_ylabel("|error| [N m]" if j == 0 else "")
    figure.tight_layout()
    for suffix in (".png", ".svg"):
        figure.savefig(out / f"test_errors{suffix}", dpi=120)
    plt.close(figure)


def task_of(config: DictConfig) -> DictConfig:
    """The run's ``task`` keys (initial error, success rule); runs before the reference
    group kept them under ``reference``."""
    return config.task if "task" in config else config.reference


def run_dirs(paths: list[Path]) -> list[Path]:
    """The control run directories under ``paths`` (other kinds left out with a warning)."""
    return find_runs(paths, CONTROL)


def tracking_table(runs: list[Path]) -> pd.DataFrame:
    rows = []
    for run in runs:
        config = OmegaConf.load(run / "config.yaml")
        summary = RunDirectory(run).summary()
        steady = summary[
            [c for c in summary.columns if c.startswith("steady_state_max_error_deg_")]
        ]
        rows.append(
            {
                "run": run.name,
                "kernel": kernel_label(OmegaConf.to_container(config.kernel)),
                "controller": str(config.controller._target_).rsplit(".", 1)[-1],
                "model": Path(str(config.model_dir)).name,
                "initial_error_rad": float(task_of(config).initial_error),
                "seeds": len(summary),
                "successes": int(summary["success"].sum()),
                "diverged": int(summary["diverged"].sum()),
                "worst_steady_state_deg": steady.max(axis=0).round(3).tolist(),
                "latency_p99_ms": float(summary["latency_p99_ms"].max()),
                "max_torque_nm": float(
                    summary[[c for c in summary.columns if c.startswith("max_torque_")]].max().max()
                ),
                "saturated_share": float(summary["saturated_share"].mean())
                if "saturated_share" in summary
                else float("nan"),
            }
        )
    return pd.DataFrame(rows)


def tracking_markdown(table: pd.DataFrame) -> str:
    lines = [
        "| controller | model | initial error [rad] | success / seeds | diverged | worst "
        "steady-state error per joint [deg] | largest commanded torque [N m] | steps the "
        "torque limits cut | p99 latency in the run [ms] |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for row in table.sort_values(["initial_error_rad", "controller", "model"]).itertuples():
        worst = " ".join(f"{v:.2f}" for v in row.worst_steady_state_deg)
        kernel = "—" if row.controller == "TrueModelFL" else f"{row.kernel} (`{row.model}`)"
        cut = "no limits" if pd.isna(row.saturated_share) else f"{100 * row.saturated_share:.1f} %"
        lines.append(
            f"| {row.controller} | {kernel} | {row.initial_error_rad:g} | "
            f"{row.successes}/{row.seeds} | {row.diverged} | {worst} | {row.max_torque_nm:.0f} "
            f"| {cut} | {row.latency_p99_ms:.3f} |"
        )
    return "\n".join(lines) + "\n"


def tracking_figure(run: Path, seed_file: Path, out: Path) -> None:
    """Joint angles vs reference, torques and tracking errors of one run (Figs. 5.4–5.6)."""
    with np.load(seed_file) as arrays:
        time, q, r = arrays["time"], arrays["positions"], arrays["reference"]
        tau, error = arrays["torques"], arrays["errors"]
    joints = q.shape[1]
    figure, axes = plt.subplots(3, joints, figsize=(2.4 * joints, 6.5), sharex=True)
    for j in range(joints):
        axes[0, j].plot(time, r[:, j], "k--", lw=1, label="r")
        axes[0, j].plot(time, q[:, j], lw=1, label="q")
        axes[0, j].set_title(f"joint {j + 1}")
        axes[1, j].plot(time[:-1], tau[:, j], lw=0.8)
        axes[2, j].plot(time, np.degrees(error[:, j]), lw=0.8)
        axes[2, j].set_xlabel("t [s]")
    axes[0, 0].set_ylabel("angle [rad]")
    axes[1, 0].set_ylabel("torque [N m]")
    axes[2, 0].set_ylabel("error [deg]")
    axes[0, 0].legend(fontsize=7)
    figure.suptitle(f"{run.parent.name}/{run.name}, {seed_file.stem}", fontsize=9)
    figure.tight_layout()
    for suffix in (".png", ".svg"):
        figure.savefig(
            out / f"tracking_{run.parent.name}_{run.name}_{seed_file.stem}{suffix}", dpi=100
        )
    plt.close(figure)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("models", nargs="*", type=Path, help="model directories")
    parser.add_argument("--runs", nargs="*", type=Path, default=[], help="runs or sweeps")
    parser.add_argument("--out", type=Path, default=Path("control_report"))
    parser.add_argument(
        "--figure-seed", type=int, default=None, help="tracking figures of this seed's runs"
    )
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    if args.models:
        table = model_table(args.models)
        table.to_csv(args.out / "nmse.csv", index=False)
        (args.out / "nmse.md").write_text(nmse_markdown(table))
        error_boxplots(args.models, table["kernel"].tolist(), args.out)
        print((args.out / "nmse.md").read_text())  # noqa: T201
    runs = run_dirs(args.runs)
    if runs:
        table = tracking_table(runs)
        table.to_csv(args.out / "tracking.csv", index=False)
        (args.out / "tracking.md").write_text(tracking_markdown(table))
        print((args.out / "tracking.md").read_text())  # noqa: T201
        if args.figure_seed is not None:
            for run in runs:
                seed_file = run / "tracking" / f"seed_{args.figure_seed:02d}.npz"
                if seed_file.is_file():
                    tracking_figure(run, seed_file, args.out)


if __name__ == "__main__":
    main()
