"""GP feedback-linearisation torque control of a simulated arm (thesis chapter 5):
``python -m runners.control kernel=gip controller=gp_fl [+experiment=fl_initial_error]``.

The GP inverse-dynamics model is fitted once per (robot, kernel, data, gp settings) and
cached in ``model_dir`` (``models/<kernel>`` by default: data sets, ``gp.pt`` of tensors,
test nMSE, ``model.json`` naming what it was fitted to); the run directory holds one
tracking run per reference seed (``summary.csv``, ``tracking/seed_KK.npz``, ``rollouts.mcap``).

The Hydra application only: the work lives in :mod:`runners.control_job`, imported when a job
starts, so ``--help`` and ``--cfg job`` answer without loading torch.
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
