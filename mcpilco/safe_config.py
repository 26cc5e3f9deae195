"""What a configuration may instantiate, and reading configs from run directories safely.

Hydra instantiates whatever a ``_target_`` names, so a config is code. Run directories are
shared (and committed), so every config we instantiate — from the command line, from a run
directory's ``config.yaml``, from an MCAP log's ``run`` metadata — is first checked here:

* a ``_target_`` must name a **class** (never a function, method or builtin) that is a
  subclass of one of mcpilco's extension points (:func:`extension_points`) — ours or a
  user's own subclass;
* its module must already be importable (installed or on ``PYTHONPATH``); a module of the
  standard library is never imported for a target (none defines such a class).

Anything else is refused with one line naming the key, before anything is built. A
refused or unimportable config can still be read as data (``OmegaConf.load``).
"""

from __future__ import annotations

import importlib
import importlib.util
import inspect
import logging
import re
import sys
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from omegaconf import DictConfig, ListConfig, OmegaConf
from omegaconf.errors import OmegaConfBaseException
from yaml import YAMLError

from mcpilco.errors import ConfigError, RefusedTargetError

log = logging.getLogger(__name__)

_DOTTED = re.compile(r"[A-Za-z][A-Za-z0-9_]*(\.[A-Za-z][A-Za-z0-9_]*)+")


def extension_points() -> tuple[type, ...]:
    """The base classes a ``_target_`` may derive from (one per concept)."""
    from mcpilco.cloth.simulation import ClothParameters
    from mcpilco.control.controllers import TrackingController
    from mcpilco.control.robot import TorqueControlledRobot
    from mcpilco.costs.base import Cost
    from mcpilco.estimators.base import StateEstimator
    from mcpilco.gp.exact import ExactGP
    from mcpilco.gp.fit import MarginalLikelihoodFit
    from mcpilco.kernels.base import Kernel
    from mcpilco.latent.cgpdm import CGPDM
    from mcpilco.models.base import ModelStructure
    from mcpilco.optim.base import PolicySearch
    from mcpilco.policies.exploration import ExplorationController
    from mcpilco.policies.rbf import SquashedRBFPolicy
    from mcpilco.systems.base import MechanicalSystem
    from mcpilco.tracking.base import TrialObserver

    return (
        MechanicalSystem,
        ModelStructure,
        Kernel,
        ExactGP,
        MarginalLikelihoodFit,
        StateEstimator,
        Cost,
        SquashedRBFPolicy,
        ExplorationController,
        PolicySearch,
        TrialObserver,
        TorqueControlledRobot,
        TrackingController,
        ClothParameters,
        CGPDM,
    )


def _import_longest_module(parts: list[str], key: str, target: str) -> tuple[Any, list[str]]:
    """Import the longest importable module prefix of ``parts``; the rest are attributes."""
    for cut in range(len(parts) - 1, 0, -1):
        name = ".".join(parts[:cut])
        try:
            found = importlib.util.find_spec(name)
        except (ImportError, ValueError):
            found = None
        if found is None:
            continue
        try:
            return importlib.import_module(name), parts[cut:]
        except Exception as error:  # a broken plug-in module: name it, one line
            raise RefusedTargetError(
                f"{key}={target!r}: importing {name} failed ({type(error).__name__}: {error})"
            ) from None
    raise RefusedTargetError(f"{key}={target!r}: no importable module (is the plug-in installed?)")


def locate_class(target: Any, key: str = "_target_") -> type:
    """The class ``target`` (a dotted path) names, if it may be instantiated (see module
    docstring); :class:`RefusedTargetError` naming ``key`` otherwise."""
    if not isinstance(target, str) or not _DOTTED.fullmatch(target):
        raise RefusedTargetError(f"{key}={target!r} is not a dotted path module.Class")
    parts = target.split(".")
    if parts[0] in sys.stdlib_module_names or parts[0] == "builtins":
        raise RefusedTargetError(
            f"{key}={target!r} is refused: the standard library defines no mcpilco component"
        )
    module, attributes = _import_longest_module(parts, key, target)
    found: Any = module
    for attribute in attributes:
        found = getattr(found, attribute, None)
        if found is None:
            raise RefusedTargetError(f"{key}={target!r}: {module.__name__} has no {attribute!r}")
    if not inspect.isclass(found):
        raise RefusedTargetError(
            f"{key}={target!r} is refused: it is a {type(found).__name__}, not a class"
        )
    roots = extension_points()
    if not issubclass(found, roots):
        names = ", ".join(f"{r.__module__}.{r.__qualname__}" for r in roots)
        raise RefusedTargetError(
            f"{key}={target!r} is refused: the class derives from none of mcpilco's "
            f"extension points ({names})"
        )
    return found


def check_targets(node: Any, where: str = "") -> None:
    """Check every ``_target_`` in ``node`` (a config, dict or list, recursively) with
    :func:`locate_class`; ``where`` prefixes the key in errors."""
    if isinstance(node, DictConfig | Mapping):
        items = node.items_ex(resolve=False) if isinstance(node, DictConfig) else node.items()
        for name, value in items:
            key = f"{where}.{name}" if where else str(name)
            if name == "_target_":
                locate_class(value, key)
            else:
                check_targets(value, key)
    elif isinstance(node, ListConfig | Sequence) and not isinstance(node, str | bytes):
        for index, value in enumerate(node):
            check_targets(value, f"{where}[{index}]")


def config_from_text(text: str, source: str) -> DictConfig:
    """A config from YAML text (e.g. a log's metadata), checked; errors name ``source``."""
    try:
        config = OmegaConf.create(text)
    except (YAMLError, OmegaConfBaseException, ValueError) as error:
        raise ConfigError(f"{source}: not a readable config ({type(error).__name__})") from None
    if not isinstance(config, DictConfig):
        raise ConfigError(f"{source}: not a config mapping")
    try:
        check_targets(config)
    except RefusedTargetError as error:
        raise RefusedTargetError(f"{source}: {error}") from None
    return config


def load_run_config(run_dir: str | Path) -> DictConfig:
    """``run_dir/config.yaml``, checked before anything in it is instantiated."""
    path = Path(run_dir) / "config.yaml"
    if not path.is_file():
        raise ConfigError(f"{path} does not exist (not a run directory?)")
    try:
        text = path.read_text()
    except (OSError, UnicodeDecodeError) as error:
        raise ConfigError(f"{path}: unreadable ({type(error).__name__})") from None
    return config_from_text(text, str(path))


def saved_system(config_text: str, source: str) -> Any | None:
    """The system a saved config names (e.g. for its drawing when replaying a log), built
    after the check; None, with a one-line warning saying why, when it cannot be (a
    refused target, a plug-in not importable here, bad parameters)."""
    from mcpilco.build import make

    try:
        config = config_from_text(config_text, source)
        if "system" not in config:  # e.g. a torque-control run: nothing to draw
            return None
        return make(config.system)
    except Exception as error:  # anything: a log must stay replayable as data
        message = str(error).splitlines()[0] if str(error) else type(error).__name__
        log.warning(
            "%s: the logged system cannot be built here (%s); going on without it", source, message
        )
        return None
