"""One-step prediction errors of each run's last model on the data of its last trial.

Thesis Fig. 4.2 compares derivative-free models by the absolute errors of their GP
predictions "on the data registered at the last trial"; here the model is the one the last
trial's policy was optimised on (fitted on every earlier trial) and the data are that
trial's rollout, prepared exactly as the trial loop prepares training data (offline
estimates for state-based models, readings for derivative-free ones), so every error is a
held-out one. Works for every model structure: the errors are those of its GP outputs
(velocity changes for speed-integration, position changes for derivative-free models).
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd
import torch

from mcpilco.build import build
from mcpilco.errors import CheckpointError, ConfigError
from mcpilco.run_storage import RunDirectory
from mcpilco.safe_config import load_run_config

log = logging.getLogger(__name__)


def run_prediction_errors(run: Path, trial: int) -> pd.DataFrame:
    """Rows (output, error) of |GP mean − target| over trial ``trial``'s rollout."""
    storage = RunDirectory(run)
    experiment = build(load_run_config(run))  # checked first (mcpilco.safe_config)
    c = experiment.components
    c.model.load_gp(storage.load_checkpoint(trial, "model"))
    trajectory = storage.load_trajectory(trial)
    states = c.estimator.offline(trajectory.measurements, trajectory.dt, trajectory.actions)
    inputs, targets = c.model.dataset([states], [trajectory.actions])
    assert c.model.gp is not None
    with torch.no_grad():
        mean, _ = c.model.gp.predict(inputs)  # [G, N]
    errors = (mean.T - targets).abs().cpu().numpy()  # [N, G]
    names = c.model.output_names
    return pd.DataFrame(
        {
            "output": np.repeat(np.array(names)[None, :], errors.shape[0], axis=0).ravel(),
            "error": errors.ravel(),
        }
    )


def prediction_errors(trials: pd.DataFrame) -> pd.DataFrame:
    """Errors of every run of ``trials`` (columns ``run``, ``trial``, ``configuration``)
    at its last learned trial, with the configuration label."""
    frames = []
    for run, group in trials.groupby("run"):
        last = int(group["trial"].max())
        if last < 1:
            continue
        try:
            frame = run_prediction_errors(Path(str(run)), last)
        except (ConfigError, CheckpointError) as error:  # a refused or broken run: skip it
            log.warning("no prediction errors for %s: %s", run, error)
            continue
        frame["configuration"] = group["configuration"].iloc[0]
        frame["trial"] = last
        frames.append(frame)
    return pd.concat(frames, ignore_index=True) if frames else pd.DataFrame()


def prediction_error_figure(errors: pd.DataFrame, out: Path) -> list[Path]:
    """Box plots of |error| per GP output, one box per configuration (PNG and SVG)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    outputs: Sequence[str] = sorted(errors["output"].unique())
    configurations = sorted(errors["configuration"].unique())
    figure, axes = plt.subplots(
        1,
        len(outputs),
        figsize=(max(4.0, 1.6 * len(configurations)) * len(outputs), 3.8),
        squeeze=False,
    )
    for axis, output in zip(axes[0], outputs, strict=True):
        data = [
            errors[(errors["output"] == output) & (errors["configuration"] == name)]["error"]
            for name in configurations
        ]
        axis.boxplot(data, showfliers=True)
        axis.set_xticks(
            range(1, len(configurations) + 1), configurations, rotation=30, ha="right", fontsize=7
        )
        axis.set_yscale("log")
        axis.set_title(f"|prediction error|, GP output {output}", fontsize=9)
    figure.tight_layout()
    paths = [out / "prediction_errors.png", out / "prediction_errors.svg"]
    for path in paths:
        figure.savefig(path, dpi=120)
    plt.close(figure)
    return paths
