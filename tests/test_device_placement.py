"""Every tensor the training loop creates names its device (``device=cuda`` runs).

No GPU here, so a tensor left on the CPU never meets a CUDA one in these tests. Instead the
whole trial loop runs under a torch-function mode that records every tensor factory called
from this package without a ``device``, outside a constructor (modules are built on the CPU
and then moved with ``.to``). Such a call is exactly what broke ``device=cuda`` for the
derivative-free model (its dataset indices were built on the CPU; found on a GPU host).
"""

from __future__ import annotations

import sys
from collections import Counter
from pathlib import Path
from types import FrameType
from typing import Any

import pytest
import torch
from hydra import compose, initialize_config_dir
from torch.overrides import TorchFunctionMode

from mcpilco.build import build
from mcpilco.run_storage import RunDirectory
from mcpilco.trial_loop import TrialLoop
from tests.test_runner import ONE_TINY_TRIAL

ROOT = Path(__file__).resolve().parent.parent
PACKAGE = str(ROOT / "mcpilco")
FACTORIES = {
    torch.arange, torch.zeros, torch.ones, torch.empty, torch.full, torch.eye,
    torch.linspace, torch.rand, torch.randn, torch.randint, torch.tensor, torch.as_tensor,
}  # fmt: skip


def _in_constructor(frame: FrameType | None) -> bool:
    while frame is not None:
        if frame.f_code.co_name == "__init__" and frame.f_code.co_filename.startswith(PACKAGE):
            return True
        frame = frame.f_back
    return False


class DevicelessFactories(TorchFunctionMode):
    """Counts ``file:line factory`` for factories called from mcpilco without a device."""

    def __init__(self) -> None:
        super().__init__()
        self.calls: Counter[str] = Counter()

    def __torch_function__(self, func: Any, types: Any, args: Any = (), kwargs: Any = None) -> Any:
        kwargs = kwargs or {}
        if func in FACTORIES and kwargs.get("device") is None:
            caller = sys._getframe(1)
            name = caller.f_code.co_filename
            if name.startswith(PACKAGE) and not _in_constructor(caller):
                self.calls[f"{name[len(PACKAGE) + 1 :]}:{caller.f_lineno} {func.__name__}"] += 1
        return func(*args, **kwargs)


@pytest.mark.parametrize(
    "overrides",
    [
        [],
        ["+experiment=cartpole_df"],
        ["+experiment=furuta_pms", "kernel=sp"],
        ["+experiment=furuta_df"],
        ["rollout_dtype=null", "kernel=se_p2"],
        ["+experiment=ball_and_plate_pms"],
        ["+experiment=ur5_df", "optimizer.num_particles=4"],
    ],
    ids=[
        "speed_integration",
        "cartpole_df",
        "furuta_pms_sp",
        "furuta_df",
        "float64_se_p2",
        "ball_and_plate_pms",
        "ur5_df",
    ],
)
def test_trial_loop_creates_no_tensor_without_a_device(
    tmp_path: Path, overrides: list[str]
) -> None:
    with initialize_config_dir(version_base="1.3", config_dir=str(ROOT / "conf")):
        cfg = compose("train", overrides=ONE_TINY_TRIAL + overrides)
    experiment = build(cfg)
    loop = TrialLoop(experiment.components, RunDirectory(tmp_path), experiment.streams, 1)
    probe = DevicelessFactories()
    with probe:
        loop.run()
    assert not probe.calls, f"tensors created without a device: {dict(probe.calls)}"
