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


def check_control_config(
    cfg: DictConfig, num_joints: int, dt: float, durations: list[float]
) -> None:
    """One-line :class:`ConfigError` naming the first bad key and its value (the
    references, of ``durations`` s, were checked when they were built)."""
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
    check_task(cfg.task, durations)
    boolean("tracking.mcap", cfg.tracking.mcap)
    rerun_mode(cfg)
    check_memory(cfg, num_joints, dt, samples, fit_points, max(durations))
    if cfg.fit_model:
        writable_directory("model_dir", cfg.model_dir)


def check_task(task: DictConfig, durations: list[float]) -> None:
    """The ``task.*`` keys: the initial error and the success rule, against the shortest
    reference's duration."""
    number(
        "task.initial_error",
        task.initial_error,
        minimum=-MAX_INITIAL_ERROR,
        maximum=MAX_INITIAL_ERROR,
    )
    settle = number("task.settle", task.settle, minimum=0)
    shortest = min(durations)
    if settle >= shortest:
        raise ConfigError(
            f"task.settle={settle!r} must be < the reference's duration ({shortest:g} s)"
        )
    number("task.threshold_deg", task.threshold_deg, above=0)


def check_memory(
    cfg: DictConfig,
    num_joints: int,
    dt: float,
    samples: int,
    fit_points: int | None,
    duration: float,
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
    steps = duration / dt
    fits_in_memory("reference.duration, robot.dt", steps * 9 * num_joints * 8.0, "a tracking run")
