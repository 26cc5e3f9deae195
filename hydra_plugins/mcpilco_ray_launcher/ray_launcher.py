"""A Hydra launcher that runs each job of a sweep as a Ray task (``hydra/launcher=ray``).

    pip install -e '.[ray]'
    python -m runners.train -m hydra/launcher=ray hydra.launcher.address=HEAD:6379 \\
        threads=1 seed='range(0,50)'

Ours rather than ``hydra-ray-launcher``: that plugin pins ``cloudpickle<3`` (and pulls boto3
for its AWS mode), which breaks the ``cloudpickle>=3`` that joblib 1.6, behind our default
local launcher, requires. Ray pickles the task with its own vendored cloudpickle, so this
launcher needs nothing but ``ray``.

Each job runs in a Ray worker through Hydra's ``run_job`` (its own run directory, logging
and ``hydra.job`` fields), with ``num_cpus`` CPUs reserved; a job that raises comes back as
a failed ``JobReturn``, so the other jobs go on and the sweep reports the failure at its
end, as with the local launchers. ``ray`` is imported only when a sweep uses this launcher.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from hydra.core.hydra_config import HydraConfig
from hydra.core.singleton import Singleton
from hydra.core.utils import JobReturn, configure_log, filter_overrides, run_job, setup_globals
from hydra.plugins.launcher import Launcher
from hydra.types import HydraContext, TaskFunction
from omegaconf import DictConfig, OmegaConf, open_dict

log = logging.getLogger(__name__)


def _run_in_worker(
    hydra_context: HydraContext,
    sweep_config: DictConfig,
    task_function: TaskFunction,
    singleton_state: dict[Any, Any],
) -> JobReturn:
    """One job, inside a Ray worker: Hydra's global state as the driver had it, then the job."""
    setup_globals()
    Singleton.set_state(singleton_state)
    HydraConfig.instance().set_config(sweep_config)
    return run_job(
        hydra_context=hydra_context,
        task_function=task_function,
        config=sweep_config,
        job_dir_key="hydra.sweep.dir",
        job_subdir_key="hydra.sweep.subdir",
    )


class RayLauncher(Launcher):
    """Runs a sweep's jobs as Ray tasks.

    Args:
        address: the cluster to join (``HOST:PORT`` of its head, or ``auto`` for the one
            running on this machine); ``None`` starts a new Ray instance here for the sweep
            (never a stale or foreign one found on the machine).
        num_cpus: CPUs reserved per job (match ``threads``).
        init: further keyword arguments of ``ray.init`` (e.g. ``runtime_env``).
    """

    def __init__(
        self,
        address: str | None = None,
        num_cpus: float = 1.0,
        init: Mapping[str, Any] | None = None,
    ) -> None:
        if num_cpus <= 0:
            raise ValueError(f"hydra.launcher.num_cpus={num_cpus} must be positive")
        self.address = address
        self.num_cpus = num_cpus
        self.init = {} if init is None else dict(init)
        self.config: DictConfig | None = None
        self.hydra_context: HydraContext | None = None
        self.task_function: TaskFunction | None = None

    def setup(
        self, *, hydra_context: HydraContext, task_function: TaskFunction, config: DictConfig
    ) -> None:
        self.config = config
        self.hydra_context = hydra_context
        self.task_function = task_function

    def _connect(self) -> None:
        import ray

        if ray.is_initialized():
            return
        init = OmegaConf.to_container(OmegaConf.create(self.init), resolve=True)
        assert isinstance(init, dict)
        init.setdefault("include_dashboard", False)
        init.setdefault("log_to_driver", True)
        log.info("Ray: %s", f"joining {self.address}" if self.address else "a local instance")
        ray.init(address=self.address or "local", **init)  # "local": always a new one

    def launch(
        self, job_overrides: Sequence[Sequence[str]], initial_job_idx: int
    ) -> Sequence[JobReturn]:
        import ray

        assert self.config is not None and self.hydra_context is not None
        assert self.task_function is not None
        setup_globals()
        configure_log(self.config.hydra.hydra_logging, self.config.hydra.verbose)
        sweep_dir = Path(str(self.config.hydra.sweep.dir))
        sweep_dir.mkdir(parents=True, exist_ok=True)
        self._connect()
        remote = ray.remote(_run_in_worker).options(num_cpus=self.num_cpus, max_retries=0)
        log.info("Ray: %d jobs into %s", len(job_overrides), sweep_dir)
        pending = []
        for offset, overrides in enumerate(job_overrides):
            index = initial_job_idx + offset
            log.info("\t#%d : %s", index, " ".join(filter_overrides(overrides)))
            sweep_config = self.hydra_context.config_loader.load_sweep_config(
                self.config, list(overrides)
            )
            with open_dict(sweep_config):
                sweep_config.hydra.job.id = f"ray_{index}"
                sweep_config.hydra.job.num = index
            pending.append(
                remote.remote(
                    self.hydra_context, sweep_config, self.task_function, Singleton.get_state()
                )
            )
        return list(ray.get(pending))
