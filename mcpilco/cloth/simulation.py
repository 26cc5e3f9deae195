"""An 8×8 cloth in MuJoCo (thesis §6.4, Fig. 6.1), its two upper corners moved by two
end-effectors.

The cloth is a MuJoCo ``flexcomp`` grid (``dim=2``) hanging in the X–Z plane; its edges are
equality constraints (a stiff ``solref`` keeps edge stretch near 1 %). Every vertex is a body
with three slide joints. The two upper corners are *driven kinematically*: before every
physics step their joint positions and velocities are set to the end-effector command, so
they follow it exactly and the rest of the cloth feels their motion through the edges.

Two simpler attachments were measured and rejected (MuJoCo 4.0.1): ``<pin>``-ning the corners
to a mocap parent body makes every vertex body a child of that mocap, so the whole cloth is
translated kinematically with it — no inertia, no swing (vertices stayed within 0.25 mm of a
rigid translation of the rest shape); ``connect`` constraints to two mocap bodies let the
corners lag by ~2 mm.

Between two samples (``sample_dt``, 0.05 s) each end-effector moves linearly from one command
to the next over ``sample_dt / timestep`` physics steps; the observation is every vertex's
position at the sample instants.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from mcpilco.checks import non_negative, positive
from mcpilco.errors import ConfigError, SimulationError
from mcpilco.extension import ExtensionPoint

GRID = 8
"""Vertices per side; the thesis's mesh is 8×8 (D = 192)."""


@dataclass(frozen=True)
class ClothParameters(ExtensionPoint):
    """Physical and numerical facts of the simulated cloth (config group ``cloth``).

    Attributes:
        side: edge length of the square cloth, m.
        mass: total mass, kg, spread over the 64 vertices (0.02 kg on 0.28 m × 0.28 m is
            255 g/m², a cotton towel).
        edge_timeconst: ``solref`` time constant of the edge constraints, s (smaller is
            stiffer; MuJoCo raises it to 2 × timestep). 0.001 at a 0.5 ms step keeps the
            largest stretch over a 120° data set at 1.4 % (mean 0.03 %); 0.002 at 1 ms let
            it reach 4.5 %, 0.002 at 2 ms 18 % (at the jerk of the first command).
        edge_damping: damping of the edges, N s/m.
        vertex_damping: damping of every vertex's motion (a linear air drag), N s/m.
        timestep: physics step, s.
        sample_dt: time between observations (and commands), s.
        height: height of the upper edge (the end-effectors) at rest, m.
    """

    side: float = 0.28
    mass: float = 0.02
    edge_timeconst: float = 0.001
    edge_damping: float = 0.001
    vertex_damping: float = 0.0005
    timestep: float = 0.0005
    sample_dt: float = 0.05
    height: float = 1.0

    def __post_init__(self) -> None:
        for name in ("side", "mass", "edge_timeconst", "timestep", "sample_dt", "height"):
            positive(name, getattr(self, name), group="cloth")
        for name in ("edge_damping", "vertex_damping"):
            non_negative(name, getattr(self, name), group="cloth")
        substeps = self.sample_dt / self.timestep
        if abs(substeps - round(substeps)) > 1e-9 or round(substeps) < 1:
            raise ConfigError(
                f"cloth.sample_dt={self.sample_dt} must be a whole multiple of "
                f"cloth.timestep={self.timestep}"
            )

    @property
    def substeps(self) -> int:
        return round(self.sample_dt / self.timestep)

    def fingerprint(self) -> dict[str, float]:
        """What makes two data sets comparable (stored with every data set)."""
        return {name: float(getattr(self, name)) for name in self.__dataclass_fields__}


def cloth_mjcf(parameters: ClothParameters) -> str:
    """The MJCF model: the cloth's upper edge at height ``height``, centred on the Z axis."""
    spacing = parameters.side / (GRID - 1)
    half = parameters.side / 2.0
    return f"""
<mujoco model="cloth">
  <option timestep="{parameters.timestep!r}" integrator="implicitfast"/>
  <worldbody>
    <flexcomp name="cloth" type="grid" dim="2" count="{GRID} {GRID} 1"
              spacing="{spacing!r} {spacing!r} {spacing!r}"
              pos="0 0 {parameters.height - half!r}"
              euler="90 0 0" mass="{parameters.mass!r}" radius="0.002">
      <edge equality="true" solref="{parameters.edge_timeconst!r} 1"
            damping="{parameters.edge_damping!r}"/>
      <contact contype="0" conaffinity="0" selfcollide="none"/>
    </flexcomp>
  </worldbody>
</mujoco>
"""


class ClothSimulation:
    """Runs end-effector command sequences on the cloth from its rest configuration.

    Attributes:
        parameters: the cloth's facts.
        corner_vertices: indices of the two upper corners (left, right) among the 64 vertices.
        corner_home: their rest positions ``[2, 3]`` (m): the end-effectors' first command.
        rest: vertex positions at rest ``[64, 3]`` (m), after settling under gravity.
    """

    num_vertices = GRID * GRID
    observation_dim = 3 * GRID * GRID
    control_dim = 6

    def __init__(self, parameters: ClothParameters, settle_seconds: float = 3.0) -> None:
        self.parameters = parameters
        self.model = mujoco.MjModel.from_xml_string(cloth_mjcf(parameters))
        self.model.dof_damping[:] = parameters.vertex_damping
        self.data = mujoco.MjData(self.model)
        self.corner_vertices = (GRID - 1, GRID * GRID - 1)
        bodies = [int(self.model.flex_vertbodyid[v]) for v in self.corner_vertices]
        self._corner_qpos = np.array(
            [self.model.jnt_qposadr[self.model.body_jntadr[b] + np.arange(3)] for b in bodies]
        )  # [2, 3]: slide joints x, y, z of each corner
        self._corner_dof = np.array(
            [self.model.jnt_dofadr[self.model.body_jntadr[b] + np.arange(3)] for b in bodies]
        )
        mujoco.mj_forward(self.model, self.data)
        self.corner_home = self.data.flexvert_xpos[list(self.corner_vertices)].copy()
        for _ in range(round(settle_seconds / parameters.timestep)):
            self._hold_corners(np.zeros((2, 3)), np.zeros((2, 3)))
            mujoco.mj_step(self.model, self.data)
        self._hold_corners(np.zeros((2, 3)), np.zeros((2, 3)))
        mujoco.mj_forward(self.model, self.data)
        self._settled = (self.data.qpos.copy(), self.data.qvel.copy())
        self.rest = self.data.flexvert_xpos.copy()

    def _hold_corners(self, offsets: np.ndarray, velocities: np.ndarray) -> None:
        """Set both corners' slide joints: offsets from home and velocities ``[2, 3]``."""
        self.data.qpos[self._corner_qpos] = offsets
        self.data.qvel[self._corner_dof] = velocities

    def edges(self) -> np.ndarray:
        """Vertex index pairs of the mesh's structural edges ``[112, 2]`` (rows, columns)."""
        index = np.arange(self.num_vertices).reshape(GRID, GRID)
        horizontal = np.stack([index[:-1, :].ravel(), index[1:, :].ravel()], axis=1)
        vertical = np.stack([index[:, :-1].ravel(), index[:, 1:].ravel()], axis=1)
        return np.concatenate([horizontal, vertical])

    def run(self, controls: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Apply end-effector displacements from rest and record the cloth.

        Args:
            controls: ``[N−1, 6]`` displacements (m) of the left then the right end-effector
                between commands t and t+1 (thesis: u_t, E = 6).
        Returns:
            ``(vertices [N, 64, 3], commands [N, 2, 3])``: vertex positions and both
            end-effector commands at the N sample instants (m).
        Raises:
            SimulationError: MuJoCo reported an instability or a vertex left a box 10 side
                lengths around the end-effectors (an exploded simulation).
        """
        controls = np.asarray(controls, dtype=np.float64)
        if controls.ndim != 2 or controls.shape[1] != self.control_dim:
            raise ConfigError(f"cloth controls must be [N-1, 6], got {controls.shape}")
        model, data = self.model, self.data
        mujoco.mj_resetData(model, data)
        data.qpos[:], data.qvel[:] = self._settled
        displacements = controls.reshape(len(controls), 2, 3)
        offsets = np.concatenate([np.zeros((1, 2, 3)), np.cumsum(displacements, axis=0)])
        mujoco.mj_forward(model, data)
        vertices = np.empty((len(offsets), self.num_vertices, 3))
        vertices[0] = data.flexvert_xpos
        substeps = self.parameters.substeps
        limit = 10.0 * self.parameters.side
        for t in range(len(displacements)):
            velocity = displacements[t] / self.parameters.sample_dt
            for k in range(substeps):
                self._hold_corners(offsets[t] + (k / substeps) * displacements[t], velocity)
                mujoco.mj_step(model, data)
            self._hold_corners(offsets[t + 1], velocity)
            mujoco.mj_forward(model, data)
            for warning in (mujoco.mjtWarning.mjWARN_BADQACC, mujoco.mjtWarning.mjWARN_BADQPOS):
                if data.warning[warning].number > 0:
                    raise SimulationError(
                        f"cloth: MuJoCo reported {warning.name} at sample {t + 1}"
                    )
            vertices[t + 1] = data.flexvert_xpos
            if not np.all(np.abs(vertices[t + 1] - self.corner_home.mean(0)) < limit):
                raise SimulationError(f"cloth: a vertex left the workspace at sample {t + 1}")
        return vertices, self.corner_home + offsets
