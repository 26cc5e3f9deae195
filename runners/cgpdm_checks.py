"""Every key of ``conf/cgpdm.yaml`` outside the built components, checked before any
simulation or training (the cloth and the CGPDM check their own keys when built), and the
memory and simulation work a run needs, estimated before anything is allocated."""

from __future__ import annotations

import re
from pathlib import Path

from omegaconf import DictConfig

from mcpilco.checks import (
    boolean,
    choice,
    fits_in_memory,
    integer,
    number,
    numbers,
    optional_integer,
    text,
    writable_directory,
)
from mcpilco.cloth import ClothSimulation
from mcpilco.errors import ConfigError
from mcpilco.latent.split import SequenceSplit, sequence_numbers
from runners.options import rerun_mode

MAX_PHYSICS_STEPS = 10**9
"""Physics steps of one simulated data set beyond which a run is refused (at the tens of
µs a step of the 8 x 8 cloth, 10⁹ steps are most of a day)."""


def check_cgpdm_config(cfg: DictConfig) -> None:
    """One-line :class:`ConfigError` naming the first bad key and its value."""
    choice("mode", cfg.mode, ("train", "generate"))
    integer("seed", cfg.seed)
    optional_integer("threads", cfg.get("threads"))
    text("device", cfg.device)
    text("cgpdm_name", cfg.cgpdm_name)
    boolean("overwrite", cfg.get("overwrite", False))
    data = cfg.data
    simulated = data.csv_dir is None and data.path is None
    number("data.range_deg", data.range_deg, above=0, maximum=360)
    ranges = numbers("data.ranges", data.ranges, minimum=0)
    if not ranges or any(not 0 < r <= 360 for r in ranges):
        raise ConfigError(f"data.ranges={ranges} must be a non-empty list of values in (0, 360]")
    integer("data.seed", data.seed)
    total = integer("data.num_sequences", data.num_sequences, minimum=2)
    integer("data.num_test", data.num_test, minimum=1)
    integer("data.num_train", data.num_train, minimum=1)
    error_units(cfg)
    rule = split_rule(cfg)
    samples = integer("excitation.num_samples", cfg.excitation.num_samples, minimum=3)
    if simulated or cfg.mode == "generate":  # sizes first: the split check lists sequences
        check_work(cfg, total, samples)
    if simulated:  # the sequence numbers are 0..num_sequences-1: checked before simulating
        rule.check_numbers(range(total))
    if data.path is not None and not Path(text("data.path", data.path)).is_file():
        raise ConfigError(f"data.path={str(data.path)!r} is not a file")
    if data.csv_dir is not None and not Path(text("data.csv_dir", data.csv_dir)).is_dir():
        raise ConfigError(f"data.csv_dir={str(data.csv_dir)!r} is not a directory")
    boolean("data.csv_duplicate_controls", data.csv_duplicate_controls)
    excitation = cfg.excitation
    number("excitation.amplitude", excitation.amplitude, above=0)
    low, high = numbers("excitation.frequency_range", excitation.frequency_range, length=2)
    if not 0 < low <= high:
        raise ConfigError(f"excitation.frequency_range={[low, high]} must be 0 < low <= high (Hz)")
    train = cfg.train
    for key in ("steps", "iterations_per_step", "history_size"):
        integer(f"train.{key}", train[key], minimum=1)
    number("train.learning_rate", train.learning_rate, above=0)
    boolean("tracking.mcap", cfg.tracking.mcap)
    rerun_mode(cfg)
    if simulated and cfg.mode == "train":
        writable_directory("data.dir", data.dir)


def check_work(cfg: DictConfig, sequences: int, samples: int) -> None:
    """Refuse a simulated data set that cannot fit in memory or would run for days: its
    arrays (``[S, N, D]`` observations, kept twice while written) and its physics steps
    (S x N x ``cloth.sample_dt / cloth.timestep``), before the cloth is built."""
    dim = ClothSimulation.observation_dim
    fits_in_memory(
        "data.num_sequences, excitation.num_samples",
        2.0 * sequences * samples * dim * 8,
        f"a data set of {sequences} sequences x {samples} samples",
    )
    cloth = cfg.cloth
    timestep, sample_dt = cloth.get("timestep"), cloth.get("sample_dt")
    if isinstance(timestep, int | float) and isinstance(sample_dt, int | float) and timestep > 0:
        steps = sequences * samples * sample_dt / timestep
        if steps > MAX_PHYSICS_STEPS:
            raise ConfigError(
                f"cloth.timestep={timestep!r}: a data set needs {steps:.3g} physics steps "
                f"(data.num_sequences x excitation.num_samples x cloth.sample_dt / "
                f"cloth.timestep), more than the {MAX_PHYSICS_STEPS:.0e} mcpilco runs"
            )


def error_units(cfg: DictConfig) -> str:
    """``data.units``, or by default ``m`` for the simulator's data and ``unitless`` for
    CSV data (whose units mcpilco cannot know); it names the summary's error columns."""
    units = cfg.data.get("units")
    if units is None:
        return "unitless" if cfg.data.csv_dir else "m"
    if not isinstance(units, str) or not re.fullmatch(r"[A-Za-z][A-Za-z0-9]*", units):
        raise ConfigError(f"data.units={units!r} must be a unit name of letters and digits")
    return units


def split_rule(cfg: DictConfig) -> SequenceSplit:
    """The run's training/test split from ``data.*`` and ``seed`` (keys checked)."""
    data = cfg.data
    return SequenceSplit(
        num_train=int(data.num_train),
        num_test=int(data.num_test),
        draw=int(cfg.seed),
        train=sequence_numbers("data.train_sequences", data.get("train_sequences")),
        test=sequence_numbers("data.test_sequences", data.get("test_sequences")),
        allow_overlap=boolean("data.allow_overlap", data.get("allow_overlap", False)),
    )


def check_training_size(cfg: DictConfig) -> None:
    """The latent dimension against the training points (PCA needs more points than
    dimensions), and the CGPDM's kernel matrices (latent map and dynamics, N² each with
    their factors and gradients) for ``data.num_train`` sequences."""
    points = split_rule(cfg).counts[0] * int(cfg.excitation.num_samples)
    latent_dim = cfg.cgpdm.get("latent_dim")
    if isinstance(latent_dim, int) and latent_dim >= points:
        raise ConfigError(
            f"cgpdm.latent_dim={latent_dim} must be below the {points} training points "
            "(training sequences x excitation.num_samples)"
        )
    fits_in_memory(
        "data.num_train (or data.train_sequences), excitation.num_samples",
        8.0 * points**2 * 8,
        f"training on {points} points",
    )
