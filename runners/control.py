"""GP feedback-linearisation torque control (thesis chapter 5): ``python -m runners.control``.

The Hydra application only; what a run does is described and done in
:mod:`runners.control_job`, imported when a job starts, so ``--help`` and ``--cfg job`` answer
without loading torch.
"""

from __future__ import annotations

from pathlib import Path

import hydra
from omegaconf import DictConfig

CONFIG_DIR = str(Path(__file__).resolve().parent.parent / "conf")


@hydra.main(version_base="1.3", config_path=CONFIG_DIR, config_name="control")
def main(cfg: DictConfig) -> None:
    """Hydra entry point: one job under the run-directory contract (:mod:`runners.job`)."""
    from runners.control_job import CONTROL_RUNNER
    from runners.job import run_job

    run_job(cfg, CONTROL_RUNNER)


if __name__ == "__main__":
    main()
