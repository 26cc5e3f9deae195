"""Every config combination composes and builds; bad values fail before any work."""

from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np
import pytest
import torch
from hydra import compose, initialize_config_dir
from hydra.errors import MissingConfigException
from hydra.utils import get_class
from omegaconf import DictConfig, OmegaConf

from mcpilco.build import build
from mcpilco.errors import ConfigError
from mcpilco.optim.policy_optimizer import frozen
from mcpilco.optim.rollout import ParticleRollout

CONFIG_DIR = Path(__file__).resolve().parent.parent / "conf"
CONTROL_ONLY = {
    "robot": None, "controller": None, "reference": None, "kernel": {"gip"}, "cloth": None,
    "cgpdm": None,
}  # fmt: skip
"""Groups (None: all of it) and options of runners.control (tests/test_control.py) and
runners.cgpdm (tests/test_cgpdm_runner.py), not of runners.train: the GIP kernel's default
input layout is the inverse dynamics' [q, q̇, q̈]."""
GROUPS = sorted(
    p.name
    for p in CONFIG_DIR.iterdir()
    if p.is_dir()
    and p.name not in ("experiment", "hydra", "budget")  # budget: derived (protocol, algorithm)
    and (p.name not in CONTROL_ONLY or CONTROL_ONLY[p.name] is not None)
)
EXPERIMENTS = sorted(
    p.stem
    for p in (CONFIG_DIR / "experiment").glob("*.yaml")
    if not p.stem.startswith(("fl_", "cgpdm_"))
)


def options(group: str) -> list[str]:
    excluded = CONTROL_ONLY.get(group) or set()
    return sorted(p.stem for p in (CONFIG_DIR / group).glob("*.yaml") if p.stem not in excluded)


def make_config(*overrides: str) -> DictConfig:
    with initialize_config_dir(version_base="1.3", config_dir=str(CONFIG_DIR)):
        return compose("train", overrides=list(overrides))


def test_every_group_is_known() -> None:
    assert {"system", "kernel", "model", "policy", "cost", "optimizer", "estimator"} <= set(GROUPS)
    assert all(options(group) for group in GROUPS)  # no empty group silently empties the product


INDEPENDENT = ("algorithm", "cost", "exploration", "optimizer", "protocol")
"""Groups whose options read nothing but the system (state size, u_max, dt): each option is
built with every system; all other groups are crossed in full."""
COUPLED = [g for g in GROUPS if g not in INDEPENDENT]


TRACKING_SYSTEMS = {"ur5"}  # systems with reference_states: tracking costs/PD need one
GYM_SYSTEMS = {  # system=gymnasium and its presets: extra overrides, position indices
    "gymnasium": (["system.env_id=InvertedPendulum-v5", "system.trial_duration=4.0"], [0, 1]),
    "gym_pendulum": ([], [0]),
    "gym_inverted_pendulum": ([], [0, 1]),
}
CROSSED_ONCE = {"gymnasium", "gym_inverted_pendulum"}
"""Built with every independent option and preset, but crossed in full only through
gym_pendulum (the same class: the full cross would add ~500 builds for no new path)."""
try:
    import gymnasium  # noqa: F401

    HAVE_GYM = True
except ImportError:  # the optional extra: those systems must say how to install it
    HAVE_GYM = False
BASIS_SYSTEMS = {"cartpole", "cartpole_mujoco", "furuta", "ball_and_plate"}  # for kernel=sp
TORCH_ODE_SYSTEMS = {"cartpole", "cartpole_mujoco", "furuta", "gym_pendulum"}  # true_dynamics


def refusal(chosen: dict[str, str]) -> str | None:
    """The one-line error an inconsistent choice must stop with (None: it must build)."""
    system = chosen["system"]
    tracking = system in TRACKING_SYSTEMS
    if system in GYM_SYSTEMS and not HAVE_GYM:
        return "needs the gymnasium package"
    if chosen.get("model") == "true_dynamics" and system not in TORCH_ODE_SYSTEMS:
        return "torch equations of motion"
    if chosen.get("kernel") == "sp" and system not in BASIS_SYSTEMS:
        return "needs a physical basis"
    if chosen.get("model") == "derivative_free" and chosen.get("estimator", "none") != "none":
        return "estimator=none"  # DF learns from raw readings
    if chosen.get("cost") in ("tracking", "tracking_positions") and not tracking:
        return "needs a tracking task"
    if chosen.get("exploration") == "pd" and not tracking:
        return "needs a tracking task"
    if chosen.get("optimizer") == "pilco":  # alone, without algorithm=pilco's model
        return "algorithm=pilco needs model=full_state"
    if chosen.get("algorithm") == "pilco":  # every system's default cost is a particle cost
        return "closed-form Gaussian expectation"
    return None


def build_choice(chosen: dict[str, str]) -> None:
    overrides = [f"{g}={o}" for g, o in chosen.items()]
    extra, gym_positions = GYM_SYSTEMS.get(chosen["system"], ([], None))
    overrides += extra
    if chosen.get("estimator", "none") != "none":  # velocity estimators: positions only
        positions = (
            gym_positions
            or get_class(
                OmegaConf.load(CONFIG_DIR / "system" / f"{chosen['system']}.yaml")._target_
            ).position_indices
        )
        overrides.append(f"system.measured_indices=[{','.join(map(str, positions))}]")
    cfg = make_config(*overrides)
    expected = refusal(chosen)
    if expected is not None:
        with pytest.raises(ConfigError, match=expected):
            build(cfg)
        return
    experiment = build(cfg)
    assert (
        experiment.components.model.new_gp().num_outputs == experiment.components.model.num_outputs
    )


@pytest.mark.parametrize(
    "choice",
    [
        c
        for c in itertools.product(*[options(g) for g in COUPLED])
        if dict(zip(COUPLED, c, strict=True))["system"] not in CROSSED_ONCE
    ],
    ids=lambda c: "-".join(c),
)
def test_every_combination_composes_and_builds(choice: tuple[str, ...]) -> None:
    build_choice(dict(zip(COUPLED, choice, strict=True)))


@pytest.mark.parametrize(
    "choice",
    [
        (group, option, system)
        for group in INDEPENDENT
        for option in options(group)
        for system in options("system")
    ],
    ids=lambda c: "-".join(c),
)
def test_every_independent_option_builds_with_every_system(choice: tuple[str, str, str]) -> None:
    group, option, system = choice
    build_choice({group: option, "system": system})


@pytest.mark.parametrize("experiment", EXPERIMENTS)
@pytest.mark.parametrize("extra", [[], ["simulate_estimator=false"], ["kernel=sp"]])
def test_experiment_presets_build(experiment: str, extra: list[str]) -> None:
    cfg = make_config(f"+experiment={experiment}", *extra)
    if experiment.startswith("gym_") and not HAVE_GYM:
        with pytest.raises(ConfigError, match="needs the gymnasium package"):
            build(cfg)
        return
    no_basis = ("ur5", "ur5_df", "gym_pendulum", "gym_inverted_pendulum")  # no physical basis
    if experiment in no_basis and "kernel=sp" in extra:
        with pytest.raises(ConfigError, match="needs a physical basis"):
            build(cfg)
        return
    c = build(cfg).components
    if experiment in ("cartpole_pms", "cartpole_df"):  # positions only, 30 Hz
        assert c.system.sensors.measured == (0, 2) and c.system.num_steps == 90
    assert c.simulate_estimator == ("simulate_estimator=false" not in extra)


@pytest.mark.parametrize(
    "experiment,axis,values",
    [
        ("ablation_kernel", "kernel", "se,se_p2,sp"),
        ("ablation_dropout", "optimizer", "mcpilco,mcpilco_no_dropout"),
        ("ablation_cost", "cost", "cartpole_swingup,cartpole_swingup_selective"),
        ("ablation_model", "model", "speed_integration,full_state"),
    ],
)
@pytest.mark.parametrize("protocol,seeds", [("paper", 50), ("quick", 10)])
def test_ablation_presets_name_their_sweep_axes(
    experiment: str, axis: str, values: str, protocol: str, seeds: int
) -> None:
    overrides = [f"+experiment={experiment}", f"protocol={protocol}"]
    with initialize_config_dir(version_base="1.3", config_dir=str(CONFIG_DIR)):
        cfg = compose("train", overrides=overrides, return_hydra_config=True)
    params = cfg.hydra.sweeper.params
    assert params[axis] == values and params.seed == f"range(0,{seeds})"
    for option in values.split(","):  # every job of the sweep builds
        optimizer = build(make_config(*overrides, f"{axis}={option}")).components.optimizer
        quick = (100, 800, 800, 100)  # conf/protocol/quick.yaml
        paper = (400, 2000, 4000, 200)  # thesis / reference code
        settings = (
            optimizer.num_particles,
            optimizer.max_steps_first_trial,
            optimizer.max_steps,
            optimizer.schedule_options["window"],
        )
        assert settings == (quick if protocol == "quick" else paper)


def test_unknown_option_lists_the_choices() -> None:
    with pytest.raises(MissingConfigException) as error:
        make_config("kernel=does_not_exist")
    assert "se_p2" in str(error.value) and "sp" in str(error.value)


@pytest.mark.parametrize(
    "override,key",
    [
        ("optimizer.num_particles=0", "optimizer.num_particles"),
        ("optimizer.num_particles=-5", "optimizer.num_particles"),
        ("system.dt=0", "system.dt"),
        ("system.dt=-0.05", "system.dt"),
        ("system.trial_duration=0", "system.trial_duration"),
        ("system.trial_duration=0.07", "system.trial_duration"),
        ("system.measurement_noise_std=0", "system.measurement_noise_std"),
        ("system.measurement_noise_std=-1e-3", "system.measurement_noise_std"),
        ("model.gp.noise_std=-1", "gp.noise_std"),
        ("model.reduction_mode=relativ", "model.reduction_mode"),
        ("model.reduction_threshold=0", "model.reduction_threshold"),
        ("policy.num_basis=0", "policy.num_basis"),
        ("dtype=float16", "dtype"),
        ("num_trials=0", "num_trials"),
        ("device=tpu", "device"),
        ("compile=sometimes", "compile"),
        ("compile_steps=0", "compile_steps"),
        ("compile_steps=2.5", "compile_steps"),
    ],
)
def test_bad_values_fail_with_the_key_in_one_line(override: str, key: str) -> None:
    with pytest.raises(ConfigError) as error:
        build(make_config(override))
    message = str(error.value)
    assert key in message and "\n" not in message


def first_rollout_cost(seed: int) -> tuple[np.ndarray, float]:
    experiment = build(
        make_config(f"seed={seed}", "optimizer.num_particles=16", "policy.num_basis=8")
    )
    c = experiment.components
    rng = experiment.streams.system
    exploration = c.system.rollout(
        c.exploration(rng=rng), c.system.sample_initial_state(rng), c.system.num_steps, rng
    )
    c.model.fit([exploration.measurements], [exploration.actions])
    rollout = ParticleRollout(
        c.model,
        c.policy,
        c.cost,
        c.estimator,
        torch.as_tensor(c.system.initial_mean),
        torch.as_tensor(c.system.initial_std),
        c.system.num_steps,
    )
    with frozen(c.model):
        cost = float(rollout(16, 0.25, experiment.streams.particles).total_cost.detach())
    return exploration.states, cost


def test_same_seed_same_run_different_seed_different_run() -> None:
    states_a, cost_a = first_rollout_cost(3)
    states_b, cost_b = first_rollout_cost(3)
    states_c, cost_c = first_rollout_cost(4)
    np.testing.assert_array_equal(states_a, states_b)
    assert cost_a == cost_b
    assert not np.array_equal(states_a, states_c) and cost_a != cost_c
