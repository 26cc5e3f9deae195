"""Stepping a MuJoCo model with the action held for one control sample (ZOH)."""

from __future__ import annotations

from typing import Any

import numpy as np

from mcpilco.errors import ConfigError, SimulationError


class MujocoSimulation:
    """A MuJoCo model (MJCF text) advanced by one control sample ``dt`` at a time.

    MuJoCo's own integrator runs ``dt / timestep`` substeps with the controls held; the
    model's joint order defines ``qpos``/``qvel``.

    Args:
        xml: the MJCF model. dt: control sampling time (s).
        timestep: MuJoCo's integration step (s); must divide ``dt``.
        integrator: MuJoCo integrator name (``RK4`` for smooth, contact-free systems).
    """

    def __init__(self, xml: str, dt: float, timestep: float = 1e-3, integrator: str = "RK4"):
        import mujoco  # imported here: only simulator-backed systems need it

        self._mujoco = mujoco
        self.model: Any = mujoco.MjModel.from_xml_string(xml)
        self.model.opt.timestep = timestep
        try:
            self.model.opt.integrator = getattr(mujoco.mjtIntegrator, f"mjINT_{integrator}")
        except AttributeError as error:
            raise ConfigError(
                f"system.integrator={integrator!r} is not a MuJoCo integrator"
            ) from error
        substeps = dt / timestep
        if abs(substeps - round(substeps)) > 1e-6 or round(substeps) < 1:
            raise ConfigError(
                f"system.timestep={timestep} must divide system.dt={dt} into whole substeps"
            )
        self.substeps = int(round(substeps))
        self.data: Any = mujoco.MjData(self.model)

    def step(
        self, qpos: np.ndarray, qvel: np.ndarray, ctrl: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Positions and velocities one sample after ``(qpos, qvel)`` under ``ctrl``."""
        data = self.data
        self._mujoco.mj_resetData(self.model, data)
        data.qpos[:] = qpos
        data.qvel[:] = qvel
        data.ctrl[:] = ctrl
        self._mujoco.mj_step(self.model, data, nstep=self.substeps)
        unstable = [
            name
            for name in ("BADQPOS", "BADQVEL", "BADQACC", "BADCTRL")
            if data.warning[getattr(self._mujoco.mjtWarning, f"mjWARN_{name}")].number > 0
        ]
        if unstable:  # MuJoCo resets such a state and carries on; we stop instead
            raise SimulationError(
                f"MuJoCo reported {', '.join(unstable)} (NaN, inf or huge values) stepping from "
                f"qpos={np.asarray(qpos).tolist()}, qvel={np.asarray(qvel).tolist()}, "
                f"ctrl={np.asarray(ctrl).tolist()}"
            )
        return data.qpos.copy(), data.qvel.copy()
