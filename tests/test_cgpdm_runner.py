"""``python -m runners.cgpdm``: one trained model per run, resumable, bad input refused
before any simulation or training."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import torch
from hydra import compose, initialize_config_dir
from hydra.utils import instantiate
from omegaconf import OmegaConf
from test_cgpdm import linear_system_data

from mcpilco.latent import TrainingData
from mcpilco.latent.training import CGPDMTraining
from mcpilco.safe_config import check_targets
from mcpilco.tracking import read_run_log

ROOT = Path(__file__).resolve().parent.parent
TINY = [
    "data.num_sequences=5", "data.num_test=2", "data.num_train=2", "excitation.num_samples=8",
    "train.steps=1", "train.iterations_per_step=5", "cloth.timestep=0.001",
    "cloth.edge_timeconst=0.002", "threads=1",
]  # fmt: skip


def run_cgpdm(
    tmp_path: Path, *overrides: str, run: str = "run"
) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "runners.cgpdm", *TINY, f"data.dir={tmp_path / 'data'}",
         f"hydra.run.dir={tmp_path / run}", *overrides],
        cwd=Path.cwd(), capture_output=True, text=True, timeout=600,
    )  # fmt: skip


def errors_in(result: subprocess.CompletedProcess[str]) -> list[str]:
    return [line for line in (result.stdout + result.stderr).splitlines() if "ERROR" in line]


def test_a_run_trains_predicts_logs_and_resumes(tmp_path: Path) -> None:
    first = run_cgpdm(tmp_path, "tracking.rerun=save")
    assert first.returncode == 0, first.stderr[-3000:]
    run = tmp_path / "run"
    summary = pd.read_csv(run / "summary.csv")
    assert summary["sequence"].tolist() == [3, 4] and summary["variant"].tolist() == ["high"] * 2
    assert (summary[["error_m", "still_error_m", "rigid_error_m"]] > 0).all().all()
    predictions = np.load(run / "predictions.npz")
    assert predictions["predicted"].shape == (2, 8, 192) and predictions["latent"].shape == (
        2,
        8,
        3,
    )
    log = read_run_log(run)
    assert sorted(set(log.rollouts["kind"])) == ["cloth", "latent"]
    assert log.trials["trial"].tolist() == [0, 1]
    assert sorted((tmp_path / "data").glob("*.npz"))  # the data set is cached
    assert (run / "recording.rrd").is_file()
    replay = subprocess.run(
        [sys.executable, "-m", "runners.replay", str(run)],
        cwd=Path.cwd(), capture_output=True, text=True, timeout=600,
    )  # fmt: skip
    assert replay.returncode == 0 and "replayed sequences [0, 1]" in replay.stderr
    verify = subprocess.run(
        [str(Path(sys.executable).parent / "rerun"), "rrd", "verify",
         str(run / "recording.rrd"), str(run / "replay.rrd")],
        capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert verify.returncode == 0, verify.stderr[-2000:]
    again = run_cgpdm(tmp_path)
    assert again.returncode == 0 and "complete; nothing to do" in again.stderr + again.stdout
    (run / "summary.csv").unlink()
    resumed = run_cgpdm(tmp_path)
    assert resumed.returncode == 0, resumed.stderr[-3000:]
    assert "loaded the model trained here before" in resumed.stderr + resumed.stdout
    reloaded = pd.read_csv(run / "summary.csv")
    pd.testing.assert_frame_equal(
        reloaded.drop(columns=["predict_seconds", "final_loss"]),
        summary.drop(columns=["predict_seconds", "final_loss"]),
    )  # fit_seconds too: the reloaded model keeps its training's time (it was NaN)
    assert (reloaded["fit_seconds"] > 0).all()


@pytest.mark.slow  # CI time (make test-slow runs it)
def test_bad_input_is_refused_before_any_simulation(tmp_path: Path) -> None:
    for overrides, message in (
        (
            ["cgpdm.latent_dim=192"],
            "cgpdm.latent_dim=192 must be below the observation dimension D=192",
        ),
        (["data.num_train=4"], "data.num_train=4 must be in [1, 3]"),
        (["cgpdm=low", "cgpdm.latent_noise=-1"], "cgpdm.latent_noise=-1 must be positive"),
        (["cloth.mass=0"], "cloth.mass must be positive"),
        (["tracking.rerun=connect"], "tracking.rerun='connect' must be off or save"),
        (["train.steps=0"], "train.steps=0 must be a positive integer"),
    ):
        result = run_cgpdm(tmp_path, *overrides)
        assert result.returncode == 2, (overrides, result.stderr[-2000:])
        assert len(errors_in(result)) == 1 and message in errors_in(result)[0], errors_in(result)
        assert not (tmp_path / "data").exists()  # nothing simulated


@pytest.mark.slow  # CI time (make test-slow runs it)
def test_a_data_set_of_another_cloth_is_refused(tmp_path: Path) -> None:
    made = run_cgpdm(tmp_path, "mode=generate", "data.ranges=[30]", run="gen")
    assert made.returncode == 0, made.stderr[-3000:]
    dataset = tmp_path / "gen" / "datasets" / "R30.npz"
    assert dataset.exists() and (tmp_path / "gen" / "rollouts.mcap").exists()
    assert pd.read_csv(tmp_path / "gen" / "summary.csv")["max_edge_stretch"].iloc[0] < 0.1
    replay = subprocess.run(
        [sys.executable, "-m", "runners.replay", str(tmp_path / "gen")],
        cwd=Path.cwd(), capture_output=True, text=True, timeout=600,
    )  # fmt: skip
    assert replay.returncode == 0 and "replayed sequences [0, 1, 2, 3, 4]" in replay.stderr
    result = run_cgpdm(tmp_path, f"data.path={dataset}", "cloth.mass=0.05")
    assert result.returncode == 2
    assert "made with cloth.mass=0.02, the config has 0.05" in errors_in(result)[0]
    assert not (tmp_path / "run" / "model.pt").exists()
    used = run_cgpdm(tmp_path, f"data.path={dataset}")
    assert used.returncode == 0, used.stderr[-3000:]


@pytest.mark.parametrize("variant", ["high", "low"])
def test_both_variants_compose_build_and_train(variant: str) -> None:
    with initialize_config_dir(version_base="1.3", config_dir=str(ROOT / "conf")):
        cfg = compose("cgpdm", overrides=[f"cgpdm={variant}", "+experiment=cgpdm_study"])
    check_targets(cfg)
    model = instantiate(cfg.cgpdm)
    kernel_parameters = {
        "high": {"latent": 3, "dynamics": 9 + 9 + 1},  # ARD SE; ARD SE + ARD linear + bias
        "low": {"latent": 1, "dynamics": 1 + 1 + 1},  # isotropic SE; α1, α2, α3
    }[variant]
    observations, controls = linear_system_data(3, 10, seed=0, observation_dim=12)
    controls = torch.cat([controls] * 3, dim=-1)  # E = 6
    model.set_data(TrainingData(observations, controls))
    counts = {
        "latent": sum(p.numel() for p in model.latent_kernel.parameters() if p.requires_grad),
        "dynamics": sum(p.numel() for p in model.dynamics_kernel.parameters() if p.requires_grad),
    }
    assert counts == kernel_parameters
    # w_y learned in both (low: the GPDM reading, issue 57); w_x only in high
    assert model.log_latent_scale.requires_grad
    assert model.log_dynamics_scale.requires_grad == (variant == "high")
    assert model.scale_log_det_factor == {"high": 1.0, "low": 2.0}[variant]
    with torch.no_grad():
        start = model.negative_log_marginal_likelihood().item()
    trace = CGPDMTraining(**OmegaConf.to_container(cfg.train) | {"steps": 2})(model)
    with torch.no_grad():  # the trace's last value is the loss of the parameters kept
        kept = model.negative_log_marginal_likelihood().item()
    assert len(trace) == 2 and trace[-1] == pytest.approx(kept, rel=1e-12) and kept < start
    latent, predicted = model.predict(controls)
    assert latent.shape == (3, 10, 3) and predicted.shape == (3, 10, 12)
