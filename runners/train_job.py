"""Train a policy with MC-PILCO: ``python -m runners.train system=cartpole kernel=sp``."""

from __future__ import annotations

import json
import logging
from pathlib import Path
from typing import Any

from omegaconf import DictConfig, OmegaConf
from tqdm import tqdm

from mcpilco.build import Experiment, build, make
from mcpilco.optim.policy_optimizer import StepInfo
from mcpilco.run_contract import TRAIN, RunContract
from mcpilco.run_storage import RESUME_OVERRIDES
from mcpilco.systems.base import MechanicalSystem
from mcpilco.tracking.base import TrialObserver
from mcpilco.tracking.metadata import run_metadata
from mcpilco.trial_loop import TrialLoop
from mcpilco.trial_report import SUMMARY_COLUMNS
from runners.job import Runner
from runners.options import rerun_mode

log = logging.getLogger("mcpilco.train")
RERUN_MODES = ("off", "save", "connect")
"""``tracking.rerun`` of a training run (it can stream to a live viewer)."""


def build_observers(
    cfg: DictConfig, run_dir: Path, system: MechanicalSystem
) -> list[TrialObserver]:
    """The MCAP logger (unless ``tracking.mcap=null``) and the Rerun stream if asked."""
    tracking = cfg.get("tracking") or {}
    observers: list[TrialObserver] = []
    if tracking.get("mcap") is not None:
        observers.append(make(tracking.mcap)(run_dir=run_dir))
    mode = rerun_mode(cfg, RERUN_MODES)
    if mode != "off":
        stream = make(tracking.rerun_stream)
        observers.append(
            stream(run_dir=run_dir, mode=mode, sketch=system.sketch, state_names=system.state_names)
        )
    return observers


def prepare(cfg: DictConfig) -> Experiment:
    """Every component built and checked (:func:`mcpilco.build.build`), before any work."""
    rerun_mode(cfg, RERUN_MODES)
    return build(cfg)


def work(
    cfg: DictConfig, experiment: Experiment, contract: RunContract, finished: list[Any]
) -> None:
    """The trial loop with a progress bar, in the claimed directory (finished trials are
    restored by the loop itself)."""
    storage = contract.storage
    run_dir = storage.path
    system = experiment.components.system
    observers = build_observers(cfg, run_dir, system)
    describe = getattr(system, "describe", None)
    if callable(describe):  # what the system took from its environment (p(x0), dt, bounds)
        storage.write_text("system.json", json.dumps(describe(), indent=1) + "\n")
    config_yaml = OmegaConf.to_yaml(cfg, resolve=True)
    metadata = run_metadata(config_yaml, cfg.seed, cfg.device, cfg.dtype)
    loop = TrialLoop(
        experiment.components,
        storage,
        experiment.streams,
        experiment.num_trials,
        observers=observers,
        metadata=metadata,
    )
    bars: dict[int, tqdm] = {}

    def on_step(trial: int, info: StepInfo) -> None:
        if trial not in bars:
            for bar in bars.values():
                bar.close()
            budget = experiment.components.optimizer.step_budget(trial)
            bars[trial] = tqdm(
                desc=f"trial {trial}/{experiment.num_trials}",
                total=budget,
                unit="step",
                bar_format=STEP_BAR if budget else None,
                dynamic_ncols=True,
            )
        bars[trial].update(1)
        bars[trial].set_postfix(
            J=f"{info.cost:.3f}", p_d=info.dropout, lr=info.learning_rate, T=info.horizon
        )

    try:
        loop.run(on_step=on_step)
    finally:
        for bar in bars.values():
            bar.close()
    table = storage.summary()
    columns = [c for c in SUMMARY_COLUMNS if c in table.columns]
    log.info(
        "summary (every column: %s):\n%s",
        storage.path / "summary.csv",
        table[columns].to_string(index=False, float_format=lambda v: f"{v:.4g}"),
    )


STEP_BAR = "{desc}: {n_fmt}/{total_fmt} steps at most [{elapsed}<{remaining} if all run{postfix}]"
"""The bar of a search with a step budget: the monitoring signal may stop it earlier, so the
estimate is an upper bound."""


TRAIN_RUNNER: Runner[Experiment] = Runner(
    kind=TRAIN, resume_overrides=RESUME_OVERRIDES, prepare=prepare, work=work
)
