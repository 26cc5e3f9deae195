"""The one place that turns a composed config into objects."""

from __future__ import annotations

import inspect
import logging
from dataclasses import dataclass
from functools import partial
from typing import Any

import numpy as np
import torch
from hydra.errors import InstantiationException
from hydra.utils import instantiate
from omegaconf import DictConfig

from mcpilco.checks import fits_in_memory
from mcpilco.errors import ConfigError
from mcpilco.optim.rollout import ParticleRollout
from mcpilco.safe_config import check_targets
from mcpilco.seeding import RandomStreams
from mcpilco.systems.base import MechanicalSystem
from mcpilco.trial_loop import Components

log = logging.getLogger(__name__)

DTYPES = {"float64": torch.float64, "float32": torch.float32}


@dataclass
class Experiment:
    """A built run: its components, random streams and trial count."""

    components: Components
    streams: RandomStreams
    num_trials: int
    dtype: torch.dtype
    device: torch.device


def resolve_device(name: str) -> torch.device:
    """``cpu``, ``cuda`` or ``cuda:K``; a clear error when CUDA is not there."""
    try:
        device = torch.device(name)
    except RuntimeError as error:
        raise ConfigError(f"device={name!r} is not a torch device") from error
    if device.type == "cuda" and not torch.cuda.is_available():
        raise ConfigError(f"device={name!r} but torch sees no CUDA device")
    if device.type not in ("cpu", "cuda"):
        raise ConfigError(f"device={name!r}: only cpu and cuda are supported")
    return device


def check_top_level(cfg: DictConfig) -> tuple[torch.dtype, torch.device]:
    """Validate the keys outside the groups; one-line errors naming key and value."""
    if cfg.dtype not in DTYPES:
        raise ConfigError(f"dtype={cfg.dtype!r} must be one of {sorted(DTYPES)}")
    rollout = cfg.get("rollout_dtype")
    if rollout is not None and rollout not in DTYPES:
        raise ConfigError(f"rollout_dtype={rollout!r} must be null or one of {sorted(DTYPES)}")
    if not isinstance(cfg.seed, int) or cfg.seed < 0:
        raise ConfigError(f"seed={cfg.seed!r} must be a non-negative integer")
    if not isinstance(cfg.num_trials, int) or cfg.num_trials < 1:
        raise ConfigError(f"num_trials={cfg.num_trials!r} must be a positive integer")
    if cfg.get("threads") is not None and (not isinstance(cfg.threads, int) or cfg.threads < 1):
        raise ConfigError(f"threads={cfg.threads!r} must be a positive integer or null")
    if not isinstance(cfg.get("compile", False), bool) and cfg.get("compile") != "auto":
        raise ConfigError(f"compile={cfg.compile!r} must be true, false or auto")
    steps = cfg.get("compile_steps", 1)
    if isinstance(steps, bool) or not isinstance(steps, int) or steps < 1:
        raise ConfigError(f"compile_steps={steps!r} must be a positive integer")
    return DTYPES[cfg.dtype], resolve_device(cfg.device)


def make(node: Any, **kwargs: Any) -> Any:
    """``hydra.utils.instantiate`` that lets our one-line :class:`ConfigError` through
    instead of Hydra's multi-line wrapper."""
    try:
        return instantiate(node, **kwargs)
    except InstantiationException as error:
        cause: BaseException | None = error
        while cause is not None and not isinstance(cause, ConfigError):
            cause = cause.__cause__
        if cause is None:
            raise
        raise cause from None


def with_system(made: Any, system: MechanicalSystem) -> Any:
    """A component whose config is a ``_partial_`` (it needs the built system, e.g. a
    tracking cost's reference) completed with ``system=``; anything else as it is."""
    return made(system=system) if isinstance(made, partial) else made


def bind_if_accepted(factory: Any, name: str, value: Any) -> Any:
    """``factory`` with ``name=value`` bound when its target takes that argument (a user's
    class need not); unchanged otherwise."""
    target = factory.func if isinstance(factory, partial) else factory
    if name in inspect.signature(target).parameters:
        return partial(factory, **{name: value})
    return factory


def exploration_factory(made: Any, system: MechanicalSystem) -> Any:
    """The exploration partial with the action size bound, ``u_max`` and ``dt`` taken from
    the built system where the config left them null (a Gymnasium environment's come from
    the environment), and the system too when the controller takes one (a PD controller
    following the task's reference)."""
    factory = partial(made, action_dim=system.action_dim)
    given = made.keywords if isinstance(made, partial) else {}
    for name, value in (("u_max", system.u_max), ("dt", system.dt)):
        if name in given and given[name] is None:
            factory = partial(factory, **{name: value})
    return bind_if_accepted(factory, "system", system)


def check_memory(cfg: DictConfig, system: MechanicalSystem) -> None:
    """Refuse, before the policy and the particles are allocated, a run whose first
    policy search cannot fit in memory: the system's trajectories, the policy's basis
    functions, and a rollout of M particles over T steps that keeps, per step, each
    particle's kernel vector against the n = T exploration samples, its basis
    activations and its state (for the backward pass), in float64."""
    steps = max(system.num_steps, system.search_steps)
    dims = system.state_dim + system.action_dim
    fits_in_memory(
        "system (trial duration / dt)",
        (cfg.num_trials + 1) * (steps + 1) * 3 * dims * 8.0,
        f"the trajectories of {steps} steps per trial",
    )
    basis = cfg.get("policy", {}).get("num_basis")
    particles = cfg.get("optimizer", {}).get("num_particles")
    if isinstance(basis, int) and basis > 0:
        fits_in_memory("policy.num_basis", 4.0 * basis * dims * 8, f"{basis} basis functions")
    if isinstance(particles, int) and particles > 0:
        per_particle = system.state_dim * steps + (basis or 0) + 4 * dims
        fits_in_memory(
            "optimizer.num_particles, policy.num_basis, system",
            2.0 * steps * particles * per_particle * 8,
            f"a rollout of {particles} particles over {steps} steps",
        )


def build(cfg: DictConfig) -> Experiment:
    """Instantiate every component (all validation happens here, before any work). Every
    ``_target_`` is checked first (:mod:`mcpilco.safe_config`): only subclasses of
    mcpilco's extension points are built."""
    check_targets(cfg)
    dtype, device = check_top_level(cfg)
    if cfg.get("threads") is not None:
        torch.set_num_threads(cfg.threads)
    streams = RandomStreams.from_seed(cfg.seed, device)
    system = make(cfg.system)
    check_memory(cfg, system)
    model = make(cfg.model, system=system, kernel=make(cfg.kernel))
    model.new_gp()  # builds a kernel now, so kernel errors surface before any work
    policy_factory = bind_if_accepted(make(cfg.policy), "angle_columns", model.policy_angle_columns)
    policy = policy_factory(
        input_dim=model.policy_input_size,
        action_dim=system.action_dim,
        u_max=system.u_max,
        generator=streams.policy_init,
    )
    estimator = make(cfg.estimator, system=system)
    model.check_estimator(estimator)
    components = Components(
        system=system,
        model=model.to(dtype=dtype, device=device),
        policy=policy.to(dtype=dtype, device=device),
        cost=with_system(make(cfg.cost), system).to(dtype=dtype, device=device),
        estimator=estimator,
        optimizer=make(cfg.optimizer),
        exploration=exploration_factory(make(cfg.exploration), system),
        simulate_estimator=bool(cfg.get("simulate_estimator", True)),
        compile="auto" if cfg.get("compile") == "auto" else bool(cfg.get("compile", False)),
        compile_steps=int(cfg.get("compile_steps", 1)),
        rollout_dtype=None if cfg.get("rollout_dtype") is None else DTYPES[cfg.rollout_dtype],
    )
    components.exploration(rng=np.random.default_rng(0))  # its errors too, before any work
    components.optimizer.check(  # the search refuses components it cannot work with
        ParticleRollout.for_system(
            system,
            components.model,
            components.policy,
            components.cost,
            estimator,
            components.simulate_estimator,
            dtype=components.rollout_dtype,
        )
    )
    return Experiment(components, streams, cfg.num_trials, dtype, device)
