"""Config checks shared by the Hydra apps (one-line errors naming the key)."""

from __future__ import annotations

from omegaconf import DictConfig

from mcpilco.errors import ConfigError


def rerun_mode(cfg: DictConfig) -> str:
    """``tracking.rerun``: off or save (one-line error otherwise)."""
    mode = "off" if cfg.tracking.rerun in (None, False) else str(cfg.tracking.rerun)
    if mode not in ("off", "save"):
        raise ConfigError(f"tracking.rerun={mode!r} must be off or save")
    return mode
