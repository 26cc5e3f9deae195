"""Per-trial model calibration and time per trial of a sweep, for :mod:`analysis.report`.

Calibration (:mod:`mcpilco.calibration`, or ``analysis.calibrate`` afterwards): the share
of real time steps inside the final policy's particles' central 95 % band (a calibrated
model covers ≈ 0.95) and the Gaussian negative log-likelihood of the real states under the
particles' mean and variance.
"""

from __future__ import annotations

import json
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import pandas as pd  # noqa: E402

COLUMNS = ("coverage_mean", "nll_mean")


def with_recomputed(trials: pd.DataFrame) -> pd.DataFrame:
    """``trials`` with the calibration figures a run lacks in its ``summary.csv`` (logged
    before they existed) taken from ``evaluation/trial_KK_calibration.json`` where
    ``analysis.calibrate`` wrote one; other rows unchanged."""
    trials = trials.copy()
    for index, row in trials.iterrows():
        if pd.notna(row.get("coverage_mean")) or row["trial"] < 1:
            continue
        path = Path(row["run"]) / "evaluation" / f"trial_{int(row['trial']):02d}_calibration.json"
        if path.is_file():
            for key, value in json.loads(path.read_text()).items():
                if key != "trial":
                    trials.loc[index, key] = value
    return trials


def calibration_table(trials: pd.DataFrame) -> pd.DataFrame:
    """Per configuration and learned trial: runs, median and quartiles of the coverage, the
    median NLL, and the median coverage of each state component."""
    learned = trials[(trials["trial"] >= 1) & trials["coverage_mean"].notna()]
    components = [c for c in trials.columns if c.startswith("coverage_") and c != "coverage_mean"]
    records = []
    for (configuration, trial), group in learned.groupby(["configuration", "trial"]):
        coverage = group["coverage_mean"]
        record = {
            "configuration": configuration,
            "trial": int(trial),
            "runs": len(group),
            "coverage_median": coverage.median(),
            "coverage_q25": coverage.quantile(0.25),
            "coverage_q75": coverage.quantile(0.75),
            "nll_median": group["nll_mean"].median(),
        }
        for column in components:
            record[f"{column}_median"] = group[column].median()
        records.append(record)
    return pd.DataFrame(records)


def calibration_markdown(table: pd.DataFrame) -> str:
    components = [
        c
        for c in table.columns
        if c.startswith("coverage_") and c.endswith("_median") and c != "coverage_median"
    ]
    names = [c.removeprefix("coverage_").removesuffix("_median") for c in components]
    header = ["configuration", "trial", "runs", "coverage median [IQR]", "NLL median"] + [
        f"coverage {n}" for n in names
    ]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for row in table.to_dict("records"):
        cells = [
            str(row["configuration"]),
            str(row["trial"]),
            str(row["runs"]),
            f"{row['coverage_median']:.2f} [{row['coverage_q25']:.2f}–{row['coverage_q75']:.2f}]",
            f"{row['nll_median']:.2f}",
            *[f"{row[c]:.2f}" for c in components],
        ]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def calibration_figure(trials: pd.DataFrame, out: Path) -> list[Path]:
    """Coverage and NLL per trial, every run a dot, the median a line, per configuration."""
    learned = trials[(trials["trial"] >= 1) & trials["coverage_mean"].notna()]
    configurations = sorted(learned["configuration"].unique())
    figure, axes = plt.subplots(1, 2, figsize=(10, 3.8))
    for index, configuration in enumerate(configurations):
        group = learned[learned["configuration"] == configuration]
        offset = (index - (len(configurations) - 1) / 2) * 0.08
        for axis, column in zip(axes, COLUMNS, strict=True):
            axis.plot(group["trial"] + offset, group[column], ".", alpha=0.4, color=f"C{index}")
            median = group.groupby("trial")[column].median()
            axis.plot(
                median.index + offset, median.values, "o-", color=f"C{index}", label=configuration
            )
    axes[0].axhline(0.95, color="k", ls="--", lw=1, label="calibrated (0.95)")
    axes[0].set_ylabel("real steps inside the particles' 95 % band")
    axes[1].set_ylabel("Gaussian NLL of the real states [nats]")
    axes[1].set_yscale("symlog")
    for axis in axes:
        axis.set_xlabel("trial")
    axes[0].legend(fontsize=7)
    figure.tight_layout()
    paths = [out / "calibration.png", out / "calibration.svg"]
    for path in paths:
        figure.savefig(path, dpi=120)
    plt.close(figure)
    return paths


def timing_table(trials: pd.DataFrame) -> pd.DataFrame:
    """Per configuration and learned trial: mean GP-fit and policy-search seconds."""
    learned = trials[trials["trial"] >= 1]
    columns = [c for c in ("fit_seconds", "optimization_seconds") if c in learned.columns]
    table = learned.groupby(["configuration", "trial"])[columns].mean().reset_index()
    table["runs"] = learned.groupby(["configuration", "trial"]).size().values
    return table


def timing_markdown(table: pd.DataFrame) -> str:
    lines = [
        "| configuration | trial | runs | GP fit [s] | policy search [s] |",
        "|---|---|---|---|---|",
    ]
    for row in table.to_dict("records"):
        lines.append(
            f"| {row['configuration']} | {row['trial']} | {row['runs']} | "
            f"{row.get('fit_seconds', float('nan')):.1f} | "
            f"{row.get('optimization_seconds', float('nan')):.0f} |"
        )
    return "\n".join(lines) + "\n"
