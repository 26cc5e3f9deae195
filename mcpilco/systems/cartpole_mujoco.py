"""The cart-pole of §2.5 simulated by MuJoCo instead of its ODE (``system=cartpole_mujoco``)."""

from __future__ import annotations

from typing import Any

import numpy as np

from mcpilco.checks import positive
from mcpilco.systems.cartpole import CartPole
from mcpilco.systems.mujoco_sim import MujocoSimulation

CARTPOLE_MJCF = """
<mujoco model="cartpole">
  <option gravity="0 0 -{gravity}"/>
  <worldbody>
    <body name="cart">
      <joint name="slider" type="slide" axis="1 0 0" damping="{friction}"/>
      <inertial pos="0 0 0" mass="{cart_mass}" diaginertia="1e-3 1e-3 1e-3"/>
      <geom type="box" size="0.1 0.05 0.03" contype="0" conaffinity="0"/>
      <body name="pole">
        <joint name="hinge" type="hinge" axis="0 -1 0"/>
        <inertial pos="0 0 -{half_length}" mass="{pole_mass}"
                  diaginertia="{rod_inertia} {rod_inertia} 1e-9"/>
        <geom type="capsule" fromto="0 0 0 0 0 -{pole_length}" size="0.01"
              contype="0" conaffinity="0" mass="0"/>
      </body>
    </body>
  </worldbody>
  <actuator>
    <motor joint="slider" gear="1" ctrllimited="true" ctrlrange="-{u_max} {u_max}"/>
  </actuator>
</mujoco>
"""


class CartPoleMujoco(CartPole):
    """Same plant, parameters, costs and success criterion as :class:`CartPole`, but each
    sample is simulated by MuJoCo (a slide joint with viscous damping b for the cart, a
    hinge with a uniform rod for the pole; θ = 0 hanging down, tip at x = p + L sin θ).

    Args:
        timestep: MuJoCo's integration step (s), dividing ``dt``. integrator: its name.
        Others: see :class:`CartPole`.
    """

    def __init__(self, *args: Any, timestep: float = 1e-3, integrator: str = "RK4", **kwargs: Any):
        super().__init__(*args, **kwargs)
        positive("timestep", timestep)
        xml = CARTPOLE_MJCF.format(
            gravity=self.gravity,
            friction=self.friction,
            cart_mass=self.cart_mass,
            pole_mass=self.pole_mass,
            pole_length=self.pole_length,
            half_length=self.pole_length / 2,
            rod_inertia=self.pole_mass * self.pole_length**2 / 12,
            u_max=self.u_max,
        )
        self.simulation = MujocoSimulation(xml, self.dt, timestep, integrator)

    def step(self, state: np.ndarray, action: np.ndarray) -> np.ndarray:
        qpos, qvel = self.simulation.step(state[[0, 2]], state[[1, 3]], action)
        return np.array([qpos[0], qvel[0], qpos[1], qvel[1]])
