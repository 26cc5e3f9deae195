"""Every key of ``conf/control.yaml`` outside the built components, checked before any
collection, fit or tracking (the robot, controller and kernel check their own keys when
they are built); and the memory the run needs, estimated before anything is allocated."""

from __future__ import annotations

import math

from omegaconf import DictConfig

from mcpilco.checks import (
    boolean,
    fits_in_memory,
    integer,
    number,
    numbers,
    optional_integer,
    text,
    writable_directory,
)
from mcpilco.errors import ConfigError
from runners.options import rerun_mode

MAX_INITIAL_ERROR = math.pi
"""rad: an initial error beyond half a turn is no tracking experiment."""


def check_control_config(cfg: DictConfig, num_joints: int, dt: float) -> None:
    """One-line :class:`ConfigError` naming the first bad key and its value."""
    integer("seed", cfg.seed)
    optional_integer("threads", cfg.get("threads"))
    text("model_dir", cfg.model_dir)
    boolean("fit_model", cfg.fit_model)
    boolean("overwrite", cfg.get("overwrite", False))
    data = cfg.data
    duration = number("data.duration", data.duration, above=0)
    downsample = integer("data.downsample", data.downsample, minimum=1)
    number("data.cutoff_hz", data.cutoff_hz, above=0, maximum=0.5 / dt)
    number("data.reference_std", data.reference_std, above=0)
    numbers("data.kp", data.kp, length=num_joints, minimum=0)
    numbers("data.kd", data.kd, length=num_joints, minimum=0)
    number("data.torque_limit", data.torque_limit, above=0)
    integer("data.train_seed", data.train_seed)
    integer("data.test_seed", data.test_seed)
    gp = cfg.gp
    number("gp.noise_std", gp.noise_std, above=0)
    samples = int(round(duration / dt)) // downsample
    fit_points = optional_integer("gp.fit_points", gp.fit_points, minimum=10)
    if fit_points is not None and fit_points > samples:
        raise ConfigError(
            f"gp.fit_points={fit_points} is more than the {samples} samples of a data set "
            "(data.duration / robot.dt / data.downsample)"
        )
    integer("gp.max_iterations", gp.max_iterations, minimum=1)
    check_reference(cfg.reference, num_joints)
    boolean("tracking.mcap", cfg.tracking.mcap)
    rerun_mode(cfg)
    check_memory(cfg, num_joints, dt, samples, fit_points)
    if cfg.fit_model:
        writable_directory("model_dir", cfg.model_dir)


def check_reference(reference: DictConfig, num_joints: int) -> None:
    """The ``reference.*`` keys: seeds, durations, the frequency law, the initial error."""
    seeds = reference.seeds
    if isinstance(seeds, str) or not hasattr(seeds, "__len__") or len(seeds) == 0:
        raise ConfigError(f"reference.seeds={seeds!r} must be a non-empty list of integers")
    values = [integer(f"reference.seeds[{i}]", s) for i, s in enumerate(seeds)]
    if len(set(values)) != len(values):
        raise ConfigError(f"reference.seeds={values} names a seed twice")
    duration = number("reference.duration", reference.duration, above=0)
    number("reference.amplitude", reference.amplitude)
    mean = reference.frequency_mean
    if isinstance(mean, int | float) and not isinstance(mean, bool):
        number("reference.frequency_mean", mean)
    else:
        numbers("reference.frequency_mean", mean, length=num_joints)
    number("reference.frequency_std", reference.frequency_std, minimum=0)
    number(
        "reference.initial_error",
        reference.initial_error,
        minimum=-MAX_INITIAL_ERROR,
        maximum=MAX_INITIAL_ERROR,
    )
    settle = number("reference.settle", reference.settle, minimum=0)
    if settle >= duration:
        raise ConfigError(f"reference.settle={settle!r} must be < reference.duration={duration!r}")
    number("reference.threshold_deg", reference.threshold_deg, above=0)


def check_memory(
    cfg: DictConfig, num_joints: int, dt: float, samples: int, fit_points: int | None
) -> None:
    """Refuse what cannot fit: the collected data (every sample of a set before
    downsampling, q, q̇, q̈, τ and the reference), the posterior's kernel matrix and
    factor per joint (n² each), the ML-II fit (autograd keeps a few m² per joint), and a
    tracking run's arrays."""
    raw = cfg.data.duration / dt
    fits_in_memory("data.duration, robot.dt", raw * 6 * num_joints * 8.0, "collecting a data set")
    posterior = 2.0 * samples**2 * 8 * num_joints
    fits_in_memory(
        "data.duration, data.downsample", posterior, f"the GP posterior on {samples} samples"
    )
    m = samples if fit_points is None else fit_points
    fits_in_memory("gp.fit_points", 4.0 * m**2 * 8 * num_joints, f"ML-II on {m} samples")
    steps = cfg.reference.duration / dt
    fits_in_memory("reference.duration, robot.dt", steps * 8 * num_joints * 8.0, "a tracking run")
