"""Train a policy with MC-PILCO: ``python -m runners.train system=cartpole kernel=sp``."""

from __future__ import annotations

import logging
from pathlib import Path

import hydra
from hydra.core.hydra_config import HydraConfig
from omegaconf import DictConfig, OmegaConf
from tqdm import tqdm

from mcpilco.build import build, make
from mcpilco.errors import ConfigError
from mcpilco.optim.policy_optimizer import StepInfo
from mcpilco.run_storage import MACHINE_KEYS, RESUME_OVERRIDES, RunDirectory
from mcpilco.safe_config import load_run_config
from mcpilco.systems.base import MechanicalSystem
from mcpilco.tracking.base import TrialObserver
from mcpilco.tracking.metadata import run_metadata
from mcpilco.trial_loop import TrialLoop
from runners.failures import run_reporting_failures
from runners.process import also_log_to, keep_freed_memory, log_torch_warnings_to_files

CONFIG_DIR = str(Path(__file__).resolve().parent.parent / "conf")
log = logging.getLogger("mcpilco.train")


def check_same_run(cfg: DictConfig, run_dir: Path) -> None:
    """A directory holding finished trials is continued only by the same experiment
    (a re-run sweep skips or completes its jobs); anything else is refused."""
    saved_path = run_dir / "config.yaml"
    if not (run_dir / "summary.csv").is_file() or not saved_path.is_file():
        return
    saved = OmegaConf.to_container(OmegaConf.load(saved_path), resolve=True)
    current = OmegaConf.to_container(cfg, resolve=True)
    assert isinstance(saved, dict) and isinstance(current, dict)
    for key in MACHINE_KEYS:
        saved.pop(key, None)
        current.pop(key, None)
    for key in [k for k, v in current.items() if v is None and k not in saved]:
        current.pop(key)  # a key added since (e.g. rollout_dtype), left at its null default
    if saved != current:
        raise ConfigError(
            f"hydra.run.dir={str(run_dir)!r} holds a different run; pick a new directory "
            f"or continue that one with resume={str(run_dir)!r}"
        )
    log.info("continuing the finished trials in %s", run_dir)


def given_on_command_line(key: str) -> bool:
    """Whether the command line sets the top-level ``key`` (``key=``, ``+key=``, ``++key=``)."""
    return any(
        override.lstrip("+").split("=", 1)[0] == key
        for override in HydraConfig.get().overrides.task
    )


def resolve_resume(cfg: DictConfig) -> tuple[DictConfig, Path]:
    """The config and directory to run in: Hydra's, or those of the run to resume.

    A resumed run keeps its saved config (checked before anything in it is built, see
    :mod:`mcpilco.safe_config`); only ``num_trials`` (to extend the run) and
    ``threads``/``device``/``compile``/``compile_steps`` (the machine) are taken from the
    command line, and only when given there.
    """
    if cfg.get("resume") is None:
        return cfg, Path(HydraConfig.get().runtime.output_dir)
    run_dir = Path(cfg.resume).expanduser().resolve()
    if not (run_dir / "config.yaml").is_file():
        raise ConfigError(f"resume={cfg.resume!r} holds no config.yaml")
    saved = load_run_config(run_dir)
    for key in RESUME_OVERRIDES:
        if given_on_command_line(key) or key not in saved:
            saved[key] = cfg.get(key)
    saved.resume = str(run_dir)
    return saved, run_dir


def build_observers(
    cfg: DictConfig, run_dir: Path, system: MechanicalSystem
) -> list[TrialObserver]:
    """The MCAP logger (unless ``tracking.mcap=null``) and the Rerun stream if asked."""
    tracking = cfg.get("tracking") or {}
    observers: list[TrialObserver] = []
    if tracking.get("mcap") is not None:
        observers.append(make(tracking.mcap)(run_dir=run_dir))
    mode = tracking.get("rerun", "off")
    mode = "off" if mode in (None, False) else str(mode)
    if mode not in ("off", "save", "connect"):
        raise ConfigError(f"tracking.rerun={mode!r} must be off, save or connect")
    if mode != "off":
        stream = make(tracking.rerun_stream)
        observers.append(
            stream(run_dir=run_dir, mode=mode, sketch=system.sketch, state_names=system.state_names)
        )
    return observers


def train(cfg: DictConfig) -> None:
    """One run, holding the run directory's lock throughout (a second process on it is
    refused): build (all validation first), then the trial loop with a progress bar."""
    cfg, run_dir = resolve_resume(cfg)
    storage = RunDirectory(run_dir)
    with storage.locked():
        run_locked(cfg, storage)


def run_locked(cfg: DictConfig, storage: RunDirectory) -> None:
    """:func:`train` once the directory is ours."""
    run_dir = storage.path
    if cfg.get("overwrite") and cfg.get("resume") is None:
        storage.clear()
        log.info("overwrite=true: cleared %s", run_dir)
    else:
        check_same_run(cfg, run_dir)
    experiment = build(cfg)
    observers = build_observers(cfg, run_dir, experiment.components.system)
    storage.clear_failure()
    config_yaml = OmegaConf.to_yaml(cfg, resolve=True)
    storage.write_text("config.yaml", config_yaml)
    log.info("run directory: %s", storage.path)
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


@hydra.main(version_base="1.3", config_path=CONFIG_DIR, config_name="train")
def main(cfg: DictConfig) -> None:
    """Hydra entry point. A failed or interrupted run leaves ``failed.txt`` in its
    directory (a refused second process leaves the live run's directory alone); in a sweep
    the error is re-raised so Hydra records the job as failed and runs the others."""
    keep_freed_memory()
    hydra_config = HydraConfig.get()
    run_dir = Path(cfg.resume) if cfg.get("resume") else Path(hydra_config.runtime.output_dir)
    if cfg.get("resume") and run_dir.is_dir():
        also_log_to(run_dir / "train.log")  # the resumed trials' log beside the earlier ones
    log_torch_warnings_to_files()
    run_reporting_failures(lambda: train(cfg), run_dir, resume_hint=True)


if __name__ == "__main__":
    main()
