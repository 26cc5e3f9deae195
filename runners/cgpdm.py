"""CGPDM of a cloth moved by two end-effectors (thesis chapter 6):
``python -m runners.cgpdm cgpdm=high data.range_deg=30 data.num_train=10 seed=0``.

One run trains one CGPDM on ``data.num_train`` sequences (draw ``seed``) of the data set of
range ``data.range_deg`` and predicts its test sequences. The data set is simulated once and
kept in ``data.dir`` (or read from ``data.path``, a file of ``mode=generate``, or from the
authors' CSV layout in ``data.csv_dir``). The run directory holds ``config.yaml``,
``summary.csv`` (one row per test sequence), ``model.pt`` (state dict), ``predictions.npz``,
``training.json``, ``training_set.json`` and ``rollouts.mcap``. The run-directory contract
(:mod:`mcpilco.run_contract`) holds: a rerun of the same config skips the test sequences in
the summary (and training, once ``model.pt`` is there); another config is refused.

``mode=generate`` writes the data sets of ``data.ranges`` into the run directory
(``datasets/*.npz`` + ``.json``, every sequence in ``rollouts.mcap``) and checks the
simulation's stability over all of them (:mod:`runners.cloth_data`).

The Hydra application only: the work lives in :mod:`runners.cgpdm_job`, imported when a job
starts, so ``--help`` and ``--cfg job`` answer without loading torch.
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
