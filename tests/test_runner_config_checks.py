"""Every key of ``conf/control.yaml`` and ``conf/cgpdm.yaml`` refuses its bad values in one
line naming the key, in the runner's ``prepare`` (before any collection, simulation or
training; issue 53 item 7). The tables below list the bad values by hand for each key, and
a test fails when a key of the configs has no entry, so a new key cannot go unchecked."""

from __future__ import annotations

import math
import re
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from hydra import compose, initialize_config_dir
from hydra.core.hydra_config import HydraConfig
from omegaconf import DictConfig, OmegaConf, open_dict

from mcpilco.errors import ConfigError

CONF = str(Path(__file__).resolve().parent.parent / "conf")
NAN, INF = math.nan, math.inf
NUMBER_BAD = [0, -1, NAN, INF, "abc"]  # for keys that must be positive and finite
FINITE_BAD = [NAN, INF, "abc"]
COUNT_BAD = [0, -1, 1.5, "abc"]  # positive integers
SEED_BAD = [-1, 1.5, "abc"]
BOOL_BAD = ["abc", 3]

CONTROL_BAD: dict[str, list[Any]] = {
    "seed": SEED_BAD,
    "threads": [0, -1, "abc"],
    "model_dir": ["", 5],
    "fit_model": BOOL_BAD,
    "overwrite": BOOL_BAD,
    "data.duration": NUMBER_BAD,
    "data.downsample": COUNT_BAD,
    "data.cutoff_hz": [*NUMBER_BAD, 600.0],  # above the 500 Hz Nyquist rate
    "data.reference_std": NUMBER_BAD,
    "data.kp": [[1, 2], "abc", [NAN] * 7, [-1] * 7],
    "data.kd": [[1, 2], "abc", [INF] * 7, [-1] * 7],
    "data.torque_limit": NUMBER_BAD,
    "data.train_seed": SEED_BAD,
    "data.test_seed": SEED_BAD,
    "gp.noise_std": NUMBER_BAD,
    "gp.fit_points": [0, -1, "abc", 10**7],
    "gp.max_iterations": COUNT_BAD,
    "reference.seeds": [[], "abc", [-1], [0, 0], [1.5]],
    "reference.duration": NUMBER_BAD,
    "reference.amplitude": FINITE_BAD,
    "reference.frequency_mean": [*FINITE_BAD, [1, 2]],
    "reference.frequency_std": [-1, *FINITE_BAD],
    "reference.offsets": [[1, 2], "abc", [NAN] * 7],
    "task.initial_error": [*FINITE_BAD, 1e6],
    "task.settle": [-1, *FINITE_BAD, 5.0],
    "task.threshold_deg": NUMBER_BAD,
    "tracking.mcap": BOOL_BAD,
    "tracking.rerun": ["connect", "abc"],
    "robot.urdf": ["no_such_robot.urdf", 5],
    "robot.num_joints": [6, "abc"],
    "robot.dt": NUMBER_BAD,
    "robot.gravity": [-1, *FINITE_BAD],
    "robot.joint_damping": [-1, *FINITE_BAD],
    "robot.joints": ["abc", ["no_such_joint"] * 7],
    "robot.torque_limit": ["abc", -1, 0, [1, 2], [NAN] * 7],
    "robot.home": [[1, 2], "abc", [INF] * 7],
    "controller.omega": NUMBER_BAD,
    "controller.zeta": NUMBER_BAD,
    "controller.prediction_dtype": ["float16", 5],
    "kernel.lengthscale": NUMBER_BAD,
    "kernel.variance": NUMBER_BAD,
    "kernel.train_variance": BOOL_BAD,
}
CONTROL_ELSEWHERE = {"resume": "a directory: refused by runners.job (test_run_contract)"}

CGPDM_BAD: dict[str, list[Any]] = {
    "mode": ["bogus", 5],
    "seed": SEED_BAD,
    "threads": [0, -1, "abc"],
    "device": ["abc", "tpu", 5],
    "overwrite": BOOL_BAD,
    "cgpdm_name": [5],
    "data.range_deg": [*NUMBER_BAD, 400],
    "data.ranges": [[], "abc", [0], [400], [NAN]],
    "data.seed": SEED_BAD,
    "data.num_sequences": [1, -1, 1.5, "abc"],
    "data.num_test": [*COUNT_BAD, 50],
    "data.num_train": [*COUNT_BAD, 41],
    "data.train_sequences": ["abc", [], [1, 1], [-1], [1.5], [True], [60]],  # 50 simulated
    "data.test_sequences": ["abc", 5, [], [2, 2], [-3], [99]],
    "data.allow_overlap": BOOL_BAD,
    "data.units": [5, "m/s", "", "1m"],
    "data.dir": ["", 5, "A_FILE/data"],  # under a file (made by the test)
    "data.path": ["no/such/file.npz", 5],
    "data.csv_dir": ["no/such/folder", 5],
    "data.csv_duplicate_controls": BOOL_BAD,
    "excitation.amplitude": NUMBER_BAD,
    "excitation.frequency_range": [[0.3], [0.3, INF], [0.6, 0.3], [0, 0.3], "abc"],
    "excitation.num_samples": [2, -1, 1.5, "abc"],
    "train.steps": COUNT_BAD,
    "train.iterations_per_step": COUNT_BAD,
    "train.learning_rate": NUMBER_BAD,
    "train.history_size": COUNT_BAD,
    "tracking.mcap": BOOL_BAD,
    "tracking.rerun": ["connect", "abc"],
    "cloth.side": NUMBER_BAD,
    "cloth.mass": NUMBER_BAD,
    "cloth.edge_timeconst": NUMBER_BAD,
    "cloth.edge_damping": [-1, *FINITE_BAD],
    "cloth.vertex_damping": [-1, *FINITE_BAD],
    "cloth.timestep": [*NUMBER_BAD, 0.0003],  # not a divisor of sample_dt
    "cloth.sample_dt": NUMBER_BAD,
    "cloth.height": NUMBER_BAD,
    "cgpdm.latent_dim": [0, -1, 1.5, "abc", 192],
    "cgpdm.latent_kernel.lengthscale": NUMBER_BAD,
    "cgpdm.latent_kernel.variance": NUMBER_BAD,
    "cgpdm.latent_kernel.train_variance": BOOL_BAD,
    "cgpdm.dynamics_kernel.terms[0].lengthscale": NUMBER_BAD,
    "cgpdm.dynamics_kernel.terms[0].variance": NUMBER_BAD,
    "cgpdm.dynamics_kernel.terms[0].train_variance": BOOL_BAD,
    "cgpdm.dynamics_kernel.terms[1].weight": NUMBER_BAD,
    "cgpdm.dynamics_kernel.terms[2].value": NUMBER_BAD,
    "cgpdm.latent_noise": NUMBER_BAD,
    "cgpdm.dynamics_noise": NUMBER_BAD,
    "cgpdm.latent_scale": NUMBER_BAD,
    "cgpdm.dynamics_scale": NUMBER_BAD,
    "cgpdm.train_latent_scales": BOOL_BAD,
    "cgpdm.train_dynamics_scales": BOOL_BAD,
    "cgpdm.min_noise": NUMBER_BAD,
    "cgpdm.center_observations": BOOL_BAD,
    "cgpdm.scale_log_det_factor": NUMBER_BAD,
}
CGPDM_ELSEWHERE = {"resume": "a directory: refused by runners.job (test_run_contract)"}


def composed(name: str) -> DictConfig:
    """The runner's default config as Hydra composes it (``${hydra:...}`` resolvable)."""
    with initialize_config_dir(config_dir=CONF, version_base="1.3"):
        cfg = compose(config_name=name, return_hydra_config=True)
    HydraConfig.instance().set_config(cfg)
    with open_dict(cfg):
        del cfg["hydra"]  # as the runner's task function gets it
    return cfg


def leaves(node: Any, prefix: str = "") -> Iterator[str]:
    """Dotted keys of every value in ``node`` (lists of mappings indexed ``[i]``)."""
    if isinstance(node, dict):
        for key, value in node.items():
            if key in ("_target_", "_partial_", "hydra"):
                continue
            yield from leaves(value, f"{prefix}.{key}" if prefix else key)
    elif isinstance(node, list) and node and all(isinstance(v, dict) for v in node):
        for index, value in enumerate(node):
            yield from leaves(value, f"{prefix}[{index}]")
    else:
        yield prefix


def with_value(cfg: DictConfig, key: str, value: Any) -> DictConfig:
    copy = cfg.copy()
    with open_dict(copy):
        OmegaConf.update(copy, key, value, merge=False)
    return copy


@pytest.mark.parametrize(
    ("name", "bad", "elsewhere"),
    [("control", CONTROL_BAD, CONTROL_ELSEWHERE), ("cgpdm", CGPDM_BAD, CGPDM_ELSEWHERE)],
)
def test_every_key_of_the_config_has_bad_values_listed(
    name: str, bad: dict[str, list[Any]], elsewhere: dict[str, str]
) -> None:
    plain = OmegaConf.to_container(composed(name), resolve=True)
    keys = set(leaves(plain))
    assert keys - set(bad) - set(elsewhere) == set(), "keys without bad values listed"
    assert set(bad) - keys == set(), "listed keys the config does not have"


def cases(bad: dict[str, list[Any]]) -> list[tuple[str, Any]]:
    return [(key, value) for key, values in bad.items() for value in values]


def refused(cfg: DictConfig, key: str, value: Any, prepare: Any) -> str:
    with pytest.raises(ConfigError) as error:
        prepare(cfg)
    message = str(error.value)
    assert "\n" not in message, message
    assert re.sub(r"\[\d+\]", "", key).rsplit(".", 1)[-1] in message, message  # names the key
    items = value if isinstance(value, list) else []  # a list's bad entry may be named alone
    shown = [repr(v) for v in [value, *items]] + [
        f"{float(v)}" for v in [value, *items] if isinstance(v, int | float)
    ]
    assert any(text in message for text in shown), message  # and the value
    return message


@pytest.mark.parametrize(("key", "value"), cases(CONTROL_BAD), ids=repr)
def test_control_refuses_every_bad_value_before_any_work(key: str, value: Any) -> None:
    from runners.control_job import prepare

    cfg = with_value(composed("control"), key, value)
    refused(cfg, key, value, prepare)


@pytest.mark.parametrize(("key", "value"), cases(CGPDM_BAD), ids=repr)
def test_cgpdm_refuses_every_bad_value_before_any_work(
    key: str, value: Any, tmp_path: Path
) -> None:
    from runners.cgpdm_job import prepare

    cfg = with_value(composed("cgpdm"), "data.dir", str(tmp_path / "data"))
    if isinstance(value, str) and value.startswith("A_FILE"):
        (tmp_path / "a_file").write_text("")
        value = value.replace("A_FILE", str(tmp_path / "a_file"))
    cfg = with_value(cfg, key, value)
    refused(cfg, key, value, prepare)
    assert not (tmp_path / "data").exists()  # nothing simulated, nothing made


def test_the_defaults_pass_the_checks(tmp_path: Path) -> None:
    from runners.cgpdm_job import prepare as prepare_cgpdm
    from runners.control_job import prepare as prepare_control

    prepare_control(with_value(composed("control"), "model_dir", str(tmp_path / "m")))
    prepare_cgpdm(with_value(composed("cgpdm"), "data.dir", str(tmp_path / "d")))
