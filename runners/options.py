"""Config checks shared by the Hydra apps (one-line errors naming the key)."""

from __future__ import annotations

from omegaconf import DictConfig

from mcpilco.errors import ConfigError


def rerun_mode(cfg: DictConfig, allowed: tuple[str, ...] = ("off", "save")) -> str:
    """``tracking.rerun``: one of ``allowed`` (null and false mean off; one-line error
    otherwise)."""
    value = (cfg.get("tracking") or {}).get("rerun", "off")
    mode = "off" if value in (None, False) else str(value)
    if mode not in allowed:
        raise ConfigError(
            f"tracking.rerun={mode!r} must be {', '.join(allowed[:-1])} or {allowed[-1]}"
        )
    return mode
