"""What a log records about the run that produced it."""

from __future__ import annotations

import importlib.metadata
import json
import subprocess
from pathlib import Path

import torch

PACKAGES = ("mcpilco", "torch", "numpy", "scipy", "pandas", "hydra-core", "mcap", "protobuf")


def package_versions() -> dict[str, str]:
    versions = {}
    for name in PACKAGES:
        try:
            versions[name] = importlib.metadata.version(name)
        except importlib.metadata.PackageNotFoundError:
            versions[name] = "not installed"
    return versions


def git_commit(directory: Path) -> str:
    """HEAD of the repository holding ``directory`` (+ ``-dirty``), or ``unknown``."""
    try:
        head = subprocess.run(
            ["git", "rev-parse", "HEAD"],
            cwd=directory,
            capture_output=True,
            text=True,
            timeout=10,
            check=True,
        ).stdout.strip()
        dirty = subprocess.run(
            ["git", "status", "--porcelain", "--untracked-files=no"],
            cwd=directory,
            capture_output=True,
            text=True,
            timeout=10,
        ).stdout
    except (OSError, subprocess.SubprocessError):
        return "unknown"
    return head + ("-dirty" if dirty.strip() else "")


def run_metadata(config_yaml: str, seed: int, device: str, dtype: str) -> dict[str, str]:
    """String key/values for the MCAP ``run`` metadata record."""
    return {
        "config": config_yaml,
        "seed": str(seed),
        "device": device,
        "dtype": dtype,
        "threads": str(torch.get_num_threads()),
        "versions": json.dumps(package_versions()),
        "git_commit": git_commit(Path(__file__).resolve().parent),
    }
