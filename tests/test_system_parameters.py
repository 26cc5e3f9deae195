"""Every built-in system refuses physically meaningless parameters, naming the key."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from mcpilco.errors import ConfigError
from mcpilco.systems import UR5, BallAndPlate, CartPole, CartPoleMujoco, FurutaPendulum

ROOT = Path(__file__).resolve().parent.parent

CASES = [
    (CartPole, ["cart_mass", "pole_mass", "pole_length"], ["friction", "gravity"]),
    (CartPoleMujoco, ["cart_mass", "pole_length", "timestep"], ["friction"]),
    (
        FurutaPendulum,
        ["arm_mass", "arm_length", "pendulum_mass", "pendulum_length", "resistance"],
        ["rotor_inertia", "arm_damping", "pendulum_damping", "gravity"],
    ),
    (BallAndPlate, ["plate_half_width", "success_window"], ["rolling_friction", "gravity"]),
    (UR5, ["gear", "timestep", "success_error_mm"], ["joint_damping", "armature"]),
]


@pytest.mark.parametrize(
    ("system", "name", "value"),
    [
        (system, name, value)
        for system, positive, non_negative in CASES
        for name, value in [(n, v) for n in positive for v in (0.0, -0.5, float("nan"))]
        + [(n, v) for n in non_negative for v in (-0.5, float("inf"))]
    ],
)
def test_bad_physical_parameter_is_a_one_line_error(system: type, name: str, value: float) -> None:
    with pytest.raises(ConfigError, match=rf"^system\.{name} must be") as error:
        system(**{name: value})
    assert "\n" not in str(error.value)


def test_negative_cart_mass_stops_the_runner_before_any_work(tmp_path: Path) -> None:
    result = subprocess.run(
        [sys.executable, "-m", "runners.train", "system.cart_mass=-0.5", f"hydra.run.dir={tmp_path}"],  # noqa: E501
        cwd=Path.cwd(), capture_output=True, text=True, timeout=600,
    )  # fmt: skip
    assert result.returncode == 2
    errors = [line for line in (result.stdout + result.stderr).splitlines() if "ERROR" in line]
    assert len(errors) == 1 and "system.cart_mass must be positive, got -0.5" in errors[0]
    assert not (tmp_path / "summary.csv").exists()
