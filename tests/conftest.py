"""Shared fixtures: tests run in float64 on the CPU with one thread."""

from __future__ import annotations

from pathlib import Path

import pytest
import torch

torch.set_num_threads(1)


@pytest.fixture
def generator() -> torch.Generator:
    return torch.Generator().manual_seed(1234)


@pytest.fixture(autouse=True)
def _work_in_a_temporary_directory(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Every test (and every process it starts with ``cwd=Path.cwd()``) works in its own
    temporary directory, so nothing a run writes by default (``runs/``, ``multirun/``,
    ``models/``, MuJoCo's ``MUJOCO_LOG.TXT``) lands in the checkout."""
    monkeypatch.chdir(tmp_path)
