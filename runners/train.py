"""Train a policy with MC-PILCO: ``python -m runners.train system=cartpole kernel=sp``.

The Hydra application only; what a run does is described and done in
:mod:`runners.train_job`, imported when a job starts, so ``--help`` and ``--cfg job`` answer
without loading torch.
"""

from __future__ import annotations

from pathlib import Path

import hydra
from omegaconf import DictConfig

CONFIG_DIR = str(Path(__file__).resolve().parent.parent / "conf")


@hydra.main(version_base="1.3", config_path=CONFIG_DIR, config_name="train")
def main(cfg: DictConfig) -> None:
    """Hydra entry point: one job under the run-directory contract (:mod:`runners.job`).
    A failed or interrupted run leaves ``failed.txt`` in its directory; in a sweep the
    error is re-raised so Hydra records the job as failed and runs the others."""
    from runners.job import run_job
    from runners.process import keep_freed_memory, log_torch_warnings_to_files
    from runners.train_job import TRAIN_RUNNER

    keep_freed_memory()
    log_torch_warnings_to_files()
    run_job(cfg, TRAIN_RUNNER)


if __name__ == "__main__":
    main()
