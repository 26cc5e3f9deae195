"""Feedback-linearisation torque controllers (thesis §5.1): the true-model reference,
GP-FL (τ = f̂(q, q̇, a)) and GP-FL-DCE (τ = B̂(q) a + n̂(q, q̇))."""

from __future__ import annotations

from abc import ABC, abstractmethod

import numpy as np
import torch

from mcpilco.checks import positive
from mcpilco.control.inverse_dynamics import GPInverseDynamics
from mcpilco.control.robot import TorqueControlledRobot
from mcpilco.errors import ConfigError
from mcpilco.extension import ExtensionPoint


class TrackingController(ExtensionPoint, ABC):
    """τ for the reference (r, ṙ, r̈) from a = r̈ + K_p e + K_d ė (eq. 5.2a), e = r − q,
    K_p = ω² I, K_d = 2ζω I (decoupled error dynamics of natural frequency ω, damping ζ).

    Subclass it for your own controller (``controller._target_=my_pkg.MyController``).

    Args:
        omega: ω in rad/s. zeta: ζ.
        prediction_dtype: float64 | float32, the GP's prediction arithmetic (GP
            controllers; the model stays fitted in float64).
    """

    needs_model: bool = False
    """Whether :meth:`bind` needs a fitted :class:`GPInverseDynamics`."""

    def __init__(
        self, omega: float = 100.0, zeta: float = 2.0, prediction_dtype: str = "float64"
    ) -> None:
        self.omega = positive("omega", omega, "controller")
        self.zeta = positive("zeta", zeta, "controller")
        if prediction_dtype not in ("float64", "float32"):
            raise ConfigError(
                f"controller.prediction_dtype={prediction_dtype!r} must be float64 or float32"
            )
        self.prediction_dtype = getattr(torch, prediction_dtype)
        self.kp, self.kd = self.omega**2, 2 * self.zeta * self.omega
        self.robot: TorqueControlledRobot | None = None
        self.model: GPInverseDynamics | None = None

    def bind(self, robot: TorqueControlledRobot, model: GPInverseDynamics | None) -> None:
        """Give the controller the robot (for its true model) and the GP model (set to
        predict in ``prediction_dtype``)."""
        self.robot, self.model = robot, model
        if model is not None and hasattr(model, "predict_in"):
            try:
                model.predict_in(self.prediction_dtype)
            except ConfigError as error:
                raise ConfigError(f"controller.prediction_dtype: {error}") from None

    def acceleration(
        self,
        positions: np.ndarray,
        velocities: np.ndarray,
        reference: tuple[np.ndarray, np.ndarray, np.ndarray],
    ) -> np.ndarray:
        """a ``[n]`` (rad/s²) of eq. 5.2a."""
        r, rd, rdd = reference
        return rdd + self.kp * (r - positions) + self.kd * (rd - velocities)

    @abstractmethod
    def torque(
        self, positions: np.ndarray, velocities: np.ndarray, acceleration: np.ndarray
    ) -> np.ndarray:
        """τ ``[n]`` (N m) that should give the joints acceleration ``a``."""

    def __call__(
        self,
        positions: np.ndarray,
        velocities: np.ndarray,
        reference: tuple[np.ndarray, np.ndarray, np.ndarray],
    ) -> np.ndarray:
        return self.torque(
            positions, velocities, self.acceleration(positions, velocities, reference)
        )


class TrueModelFL(TrackingController):
    """τ = B(q) a + n(q, q̇) with the robot's own rigid-body model (the reference)."""

    def torque(
        self, positions: np.ndarray, velocities: np.ndarray, acceleration: np.ndarray
    ) -> np.ndarray:
        return self.robot.inverse_dynamics(positions, velocities, acceleration)


class GPFL(TrackingController):
    """GP-FL: τ = f̂(q, q̇, a), the GP's inverse dynamics at the commanded acceleration."""

    needs_model = True

    def torque(
        self, positions: np.ndarray, velocities: np.ndarray, acceleration: np.ndarray
    ) -> np.ndarray:
        assert self.model is not None
        inputs = torch.from_numpy(np.concatenate([positions, velocities, acceleration]))[None]
        return self.model.torques(inputs)[0].numpy()


class GPFLDCE(TrackingController):
    """GP-FL-DCE: τ = B̂(q) a + n̂(q, q̇) with B̂, n̂ estimated from the GP (eq. 5.7–5.9).

    With a model affine in q̈ (the GIP kernel) B̂ a + n̂ equals f̂(q, q̇, a) exactly
    (§5.4.2), so the torque is that one GP row instead of n + 2 (the same number, a
    fraction of the cost; tested against the components).
    """

    needs_model = True

    def torque(
        self, positions: np.ndarray, velocities: np.ndarray, acceleration: np.ndarray
    ) -> np.ndarray:
        assert self.model is not None
        if getattr(self.model, "affine_in_accelerations", False):
            inputs = np.concatenate([positions, velocities, acceleration])
            return self.model.torques(torch.from_numpy(inputs)[None])[0].numpy()
        inertia, bias, _ = self.model.components(
            torch.from_numpy(positions), torch.from_numpy(velocities)
        )
        return (inertia.numpy() @ acceleration) + bias.numpy()
