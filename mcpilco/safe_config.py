"""What a configuration may instantiate, and reading configs from run directories safely.

Hydra instantiates whatever a ``_target_`` names, so a config is code. Run directories are
shared (and committed), so every config we instantiate — from the command line, from a run
directory's ``config.yaml``, from an MCAP log's ``run`` metadata — is first checked here:

* a ``_target_`` must name a **class** (never a function, method or builtin) that is a
  subclass of one of mcpilco's extension points (a base class that derives from
  :class:`mcpilco.extension.ExtensionPoint`) — ours or a user's own subclass;
* its module must already be importable **on purpose** (:func:`check_module_origin`): an
  installed package, or a module or package (with ``__init__.py``) found through a
  ``PYTHONPATH`` entry — never a plain folder, never a file inside the directory being
  read, and never a module that imports only because it lies in the working directory
  (``python -m`` puts that on the path by itself); a module of the standard library is
  never imported for a target (none defines such a class).

Nothing is executed to decide: the top-level package is located with ``find_spec`` (which
runs no code for a top-level name) and checked before anything under it is imported.

Anything else is refused with one line naming the key, before anything is built. A
refused or unimportable config can still be read as data (``OmegaConf.load``).
"""

from __future__ import annotations

import importlib
import importlib.metadata
import importlib.util
import inspect
import logging
import os
import re
import sys
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from omegaconf import DictConfig, ListConfig, OmegaConf
from omegaconf.errors import OmegaConfBaseException
from yaml import YAMLError

from mcpilco.errors import ConfigError, RefusedTargetError
from mcpilco.extension import ExtensionPoint, extension_points

log = logging.getLogger(__name__)

_DOTTED = re.compile(r"[A-Za-z][A-Za-z0-9_]*(\.[A-Za-z][A-Za-z0-9_]*)+")


def _implicit_roots() -> list[Path]:
    """The folders Python searches only because of how it was started (the working
    directory for ``python -m`` and ``-c``, a script's own folder), not because anyone put
    them on the path: ``sys.path[0]`` and the working directory, unless ``PYTHONPATH``
    names them too."""
    entries = os.environ.get("PYTHONPATH", "").split(os.pathsep)
    explicit = {_resolved(entry) for entry in entries if entry}
    implicit = {Path.cwd().resolve()}
    if not sys.flags.safe_path and sys.path:
        implicit.add(_resolved(sys.path[0]))
    return [root for root in implicit if root not in explicit]


def _resolved(entry: str) -> Path:
    return Path(entry or ".").resolve()


def _inside(path: Path, folder: Path) -> bool:
    return path == folder or folder in path.parents


def _installed(top: str) -> bool:
    """Whether an installed distribution declares the top-level package ``top``."""
    return top in importlib.metadata.packages_distributions()


def check_module_origin(top: str, key: str, target: str, untrusted: Path | None = None) -> None:
    """The import rule: refuse to import the top-level module ``top`` of ``target`` unless
    it is already imported, or a regular module or package (a file, or a folder with an
    ``__init__.py``) that lies outside ``untrusted`` (the run directory being read) and is
    either installed or found through an explicit ``PYTHONPATH`` entry or site folder —
    never a folder that imports only because it lies in the working directory. Nothing is
    executed to decide (``find_spec`` of a top-level name runs no code)."""
    if top in sys.modules:
        return
    try:
        spec = importlib.util.find_spec(top)
    except (ImportError, ValueError):
        spec = None
    if spec is None:
        raise RefusedTargetError(
            f"{key}={target!r}: no importable module (is the plug-in installed?)"
        )
    if spec.origin is None or not spec.has_location:
        raise RefusedTargetError(
            f"{key}={target!r} is refused: {top!r} is a plain folder (no __init__.py), not an "
            "installed package or a module on PYTHONPATH"
        )
    location = Path(spec.origin).resolve()
    if untrusted is not None and _inside(location, untrusted.resolve()):
        raise RefusedTargetError(
            f"{key}={target!r} is refused: {location} lies inside {untrusted}, the directory "
            "being read; mcpilco never runs code from a run directory"
        )
    # the sys.path entry that provides it: a module's folder, a package's parent folder
    entry = location.parent if spec.submodule_search_locations is None else location.parent.parent
    if entry in _implicit_roots() and not _installed(top):
        raise RefusedTargetError(
            f"{key}={target!r} is refused: {location} imports only because it lies in the "
            "working directory; install the plug-in or put its folder on PYTHONPATH"
        )


def _import_longest_module(
    parts: list[str], key: str, target: str, untrusted: Path | None
) -> tuple[Any, list[str]]:
    """Import the longest importable module prefix of ``parts`` (after
    :func:`check_module_origin` allowed its top-level package); the rest are attributes."""
    check_module_origin(parts[0], key, target, untrusted)
    for cut in range(len(parts) - 1, 0, -1):
        name = ".".join(parts[:cut])
        try:
            found = importlib.util.find_spec(name)
        except (ImportError, ValueError):
            found = None
        except Exception as error:  # the allowed package's own __init__ failed
            raise RefusedTargetError(
                f"{key}={target!r}: importing {name} failed ({type(error).__name__}: {error})"
            ) from None
        if found is None:
            continue
        if (
            untrusted is not None
            and found.origin
            and _inside(Path(found.origin).resolve(), untrusted.resolve())
        ):
            raise RefusedTargetError(
                f"{key}={target!r} is refused: {found.origin} lies inside {untrusted}, the "
                "directory being read; mcpilco never runs code from a run directory"
            )
        try:
            return importlib.import_module(name), parts[cut:]
        except Exception as error:  # a broken plug-in module: name it, one line
            raise RefusedTargetError(
                f"{key}={target!r}: importing {name} failed ({type(error).__name__}: {error})"
            ) from None
    raise RefusedTargetError(f"{key}={target!r}: no importable module (is the plug-in installed?)")


def locate_class(target: Any, key: str = "_target_", untrusted: Path | None = None) -> type:
    """The class ``target`` (a dotted path) names, if it may be instantiated (see module
    docstring); :class:`RefusedTargetError` naming ``key`` otherwise. ``untrusted``: the
    directory the config was read from (no module inside it is ever imported)."""
    if not isinstance(target, str) or not _DOTTED.fullmatch(target):
        raise RefusedTargetError(f"{key}={target!r} is not a dotted path module.Class")
    parts = target.split(".")
    if parts[0] in sys.stdlib_module_names or parts[0] == "builtins":
        raise RefusedTargetError(
            f"{key}={target!r} is refused: the standard library defines no mcpilco component"
        )
    module, attributes = _import_longest_module(parts, key, target, untrusted)
    found: Any = module
    for attribute in attributes:
        found = getattr(found, attribute, None)
        if found is None:
            raise RefusedTargetError(f"{key}={target!r}: {module.__name__} has no {attribute!r}")
    if not inspect.isclass(found):
        raise RefusedTargetError(
            f"{key}={target!r} is refused: it is a {type(found).__name__}, not a class"
        )
    if not issubclass(found, ExtensionPoint) or found is ExtensionPoint:
        names = ", ".join(f"{r.__module__}.{r.__qualname__}" for r in extension_points())
        raise RefusedTargetError(
            f"{key}={target!r} is refused: the class derives from none of mcpilco's "
            f"extension points ({names})"
        )
    return found


def check_targets(node: Any, where: str = "", untrusted: Path | None = None) -> None:
    """Check every ``_target_`` in ``node`` (a config, dict or list, recursively) with
    :func:`locate_class`; ``where`` prefixes the key in errors; ``untrusted``: the
    directory the config was read from."""
    if isinstance(node, DictConfig | Mapping):
        items = node.items_ex(resolve=False) if isinstance(node, DictConfig) else node.items()
        for name, value in items:
            key = f"{where}.{name}" if where else str(name)
            if name == "_target_":
                locate_class(value, key, untrusted)
            else:
                check_targets(value, key, untrusted)
    elif isinstance(node, ListConfig | Sequence) and not isinstance(node, str | bytes):
        for index, value in enumerate(node):
            check_targets(value, f"{where}[{index}]", untrusted)


def config_from_text(text: str, source: str, untrusted: Path | None = None) -> DictConfig:
    """A config from YAML text (e.g. a log's metadata), checked; errors name ``source``;
    ``untrusted``: the directory it was read from (see :func:`check_module_origin`)."""
    try:
        config = OmegaConf.create(text)
    except (YAMLError, OmegaConfBaseException, ValueError) as error:
        raise ConfigError(f"{source}: not a readable config ({type(error).__name__})") from None
    if not isinstance(config, DictConfig):
        raise ConfigError(f"{source}: not a config mapping")
    try:
        check_targets(config, untrusted=untrusted)
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
    return config_from_text(text, str(path), untrusted=Path(run_dir))


def saved_system(config_text: str, source: str, untrusted: Path | None = None) -> Any | None:
    """The system a saved config names (e.g. for its drawing when replaying a log), built
    after the check; None, with a one-line warning saying why, when it cannot be (a
    refused target, a plug-in not importable here, bad parameters)."""
    from mcpilco.build import make

    try:
        config = config_from_text(config_text, source, untrusted)
        if "system" not in config:  # e.g. a torque-control run: nothing to draw
            return None
        return make(config.system)
    except Exception as error:  # anything: a log must stay replayable as data
        message = str(error).splitlines()[0] if str(error) else type(error).__name__
        log.warning(
            "%s: the logged system cannot be built here (%s); going on without it", source, message
        )
        return None
