"""Read a sweep's run directories into one table (one row per run and finished trial)."""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

import pandas as pd
from hydra import compose, initialize_config_dir
from hydra.core.global_hydra import GlobalHydra
from omegaconf import OmegaConf

from analysis.study_tags import distinguished_labels, flatten
from analysis.thesis import budget_tag, configuration_label

CONFIG_DIR = Path(__file__).resolve().parent.parent / "conf"


def current_defaults() -> dict[str, object] | None:
    """Today's ``conf/train.yaml`` composed without overrides, flattened; None inside a
    running Hydra application (whose own config directory is not ours to replace)."""
    if GlobalHydra.instance().is_initialized():
        return None
    with initialize_config_dir(version_base="1.3", config_dir=str(CONFIG_DIR)):
        config = OmegaConf.to_container(compose("train"), resolve=True)
    assert isinstance(config, dict)
    return flatten(config)


def load_sweep(paths: Iterable[Path]) -> tuple[pd.DataFrame, list[Path]]:
    """One row per (run, trial) of every finished trial under ``paths``, with the run's
    configuration label (:func:`~analysis.study_tags.distinguished_labels`: runs that share
    a thesis-style label but differ in another config value get that value appended), seed
    and directory; plus the run directories that failed."""
    summaries, configs, failed = {}, {}, []
    runs = sorted({p.parent for path in paths for p in Path(path).rglob("config.yaml")})
    for run in runs:
        if (run / "failed.txt").is_file():
            failed.append(run)
        if not (run / "summary.csv").is_file():
            continue
        config = OmegaConf.to_container(OmegaConf.load(run / "config.yaml"), resolve=True)
        assert isinstance(config, dict)
        configs[str(run)] = config
        summaries[str(run)] = pd.read_csv(run / "summary.csv")
    labels = distinguished_labels(
        {run: configuration_label(config) for run, config in configs.items()},
        configs,
        current_defaults() if configs else None,
    )
    for run, config in configs.items():  # after the runs' own differences, the thesis's
        tag = budget_tag(config)
        labels[run] += f" [{tag}]" if tag else ""
    rows = []
    for run, summary in summaries.items():
        summary["configuration"] = labels[run]
        summary["seed"] = configs[run]["seed"]
        summary["run"] = run
        rows.append(summary)
    table = pd.concat(rows, ignore_index=True) if rows else pd.DataFrame()
    if "success" in table.columns:  # absent for a system without a success criterion
        table["success"] = table["success"].astype("boolean").fillna(False).astype(bool)
    return table, failed
