"""CGPDM of a cloth (thesis chapter 6): ``python -m runners.cgpdm``.

The Hydra application only; what a run does is described and done in
:mod:`runners.cgpdm_job`, imported when a job starts, so ``--help`` and ``--cfg job`` answer
without loading torch.
"""

from __future__ import annotations

from pathlib import Path

import hydra
from omegaconf import DictConfig

CONFIG_DIR = str(Path(__file__).resolve().parent.parent / "conf")


@hydra.main(version_base="1.3", config_path=CONFIG_DIR, config_name="cgpdm")
def main(cfg: DictConfig) -> None:
    """Hydra entry point: one job under the run-directory contract (:mod:`runners.job`);
    ``mode`` picks the kind of run (a bad ``mode`` is refused by the check of every key)."""
    from runners.cgpdm_job import runner_for
    from runners.job import run_job

    run_job(cfg, runner_for(cfg))


if __name__ == "__main__":
    main()
