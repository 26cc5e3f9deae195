"""Train a policy with MC-PILCO: ``python -m runners.train system=cartpole kernel=sp``."""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

import hydra
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
from runners.job import Runner, run_job
from runners.options import rerun_mode
from runners.process import keep_freed_memory, log_torch_warnings_to_files

CONFIG_DIR = str(Path(__file__).resolve().parent.parent / "conf")
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
    observers = build_observers(cfg, run_dir, experiment.components.system)
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
            bars[trial] = tqdm(desc=f"trial {trial}/{experiment.num_trials}", unit="step")
        bars[trial].update(1)
        bars[trial].set_postfix(
            J=f"{info.cost:.3f}", p_d=info.dropout, lr=info.learning_rate, T=info.horizon
        )

    try:
        loop.run(on_step=on_step)
    finally:
        for bar in bars.values():
            bar.close()
    log.info("summary:\n%s", storage.summary().to_string(index=False))


TRAIN_RUNNER: Runner[Experiment] = Runner(
    kind=TRAIN, resume_overrides=RESUME_OVERRIDES, prepare=prepare, work=work
)


@hydra.main(version_base="1.3", config_path=CONFIG_DIR, config_name="train")
def main(cfg: DictConfig) -> None:
    """Hydra entry point: one job under the run-directory contract (:mod:`runners.job`).
    A failed or interrupted run leaves ``failed.txt`` in its directory; in a sweep the
    error is re-raised so Hydra records the job as failed and runs the others."""
    keep_freed_memory()
    log_torch_warnings_to_files()
    run_job(cfg, TRAIN_RUNNER)


if __name__ == "__main__":
    main()
