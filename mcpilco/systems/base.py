"""The system interface: what the learning algorithm needs to know about a plant."""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Sequence
from typing import Protocol

import numpy as np
import torch
from scipy.integrate import solve_ivp

from mcpilco.checks import positive, require_finite
from mcpilco.errors import ConfigError, NonFiniteError, SimulationError
from mcpilco.extension import ExtensionPoint
from mcpilco.systems.sensors import Sensors
from mcpilco.trajectory import Trajectory


class Controller(Protocol):
    """Maps the latest measurement ``[d_x]`` at control step ``step`` to an action ``[d_u]``."""

    def __call__(self, measurement: np.ndarray, step: int) -> np.ndarray: ...


class MechanicalSystem(ExtensionPoint, ABC):
    """A plant with generalised positions ``q`` and velocities ``q̇``.

    The state is ordered as the subclass says; ``position_indices[k]`` and
    ``velocity_indices[k]`` name the k-th coordinate and its velocity. Angles (revolute
    coordinates) are listed in ``angle_indices`` and enter GP and policy inputs as sin/cos.

    Args:
        dt: sampling time in seconds.
        trial_duration: length of one trial in seconds.
        u_max: bound on every action component (|u| ≤ u_max).
        measurement_noise_std: std of the additive white Gaussian sensor noise, one value
            per measured component or one for all.
        initial_mean: mean of p(x0), ``[d_x]``.
        initial_std: std of p(x0) (diagonal), one value per component or one for all; the
            half-width of each component's interval when p(x0) is uniform.
        measured_indices: the state components the sensors read (None: all; a partially
            measurable system reads positions only, see :class:`Sensors`).
        quantization: resolution of the readings (encoders, cameras), None for none.
        initial_distribution: ``normal`` (x0 ~ N(mean, diag(std²))) or ``uniform``
            (each component uniform on mean ± std, e.g. a ball anywhere on a plate).
    """

    position_indices: tuple[int, ...] = ()
    velocity_indices: tuple[int, ...] = ()
    angle_indices: tuple[int, ...] = ()
    action_dim: int = 1
    state_names: tuple[str, ...] = ()
    """Labels of the state components with units, for plots (``x0``, ``x1``, ... if empty)."""
    reference_states: np.ndarray | None = None
    """For tracking tasks: the state the system should be in at each sample, ``[T+1, d_x]``
    (policies then also read the error to it, tracking costs compare with it); None for
    tasks with a fixed target."""
    exact_readings_allowed: bool = False
    """Whether ``measurement_noise_std`` may be 0 (readings equal to the state)."""
    known_coordinates: tuple[int, ...] = ()
    """Coordinates k (positions ``position_indices[k]`` and their velocities) whose next
    values the system knows exactly from state and action (see :meth:`known_transition`)."""

    def __init__(
        self,
        dt: float,
        trial_duration: float,
        u_max: float,
        measurement_noise_std: float | Sequence[float],
        initial_mean: Sequence[float],
        initial_std: float | Sequence[float],
        measured_indices: Sequence[int] | None = None,
        quantization: float | Sequence[float] | None = None,
        initial_distribution: str = "normal",
    ) -> None:
        if initial_distribution not in ("normal", "uniform"):
            raise ConfigError(
                f"system.initial_distribution={initial_distribution!r} must be normal or uniform"
            )
        self.initial_distribution = initial_distribution
        self.dt = positive("dt", dt)
        self.trial_duration = positive("trial_duration", trial_duration)
        self.u_max = positive("u_max", u_max)
        self.sensors = Sensors(
            self.state_dim,
            measured_indices,
            measurement_noise_std,
            quantization,
            allow_exact=self.exact_readings_allowed,
        )
        self.initial_mean = np.asarray(initial_mean, dtype=np.float64)
        if self.initial_mean.shape != (self.state_dim,):
            raise ConfigError(
                f"system.initial_mean must have {self.state_dim} entries, got {initial_mean!r}"
            )
        self.initial_std = self._per_state("initial_std", initial_std)
        if np.any(self.initial_std < 0):
            raise ConfigError(f"system.initial_std must be >= 0, got {initial_std!r}")
        steps = self.trial_duration / self.dt
        if abs(steps - round(steps)) > 1e-6 or round(steps) < 1:
            raise ConfigError(
                f"system.trial_duration={trial_duration} is not a whole number of dt={dt} steps"
            )

    def _per_state(self, name: str, value: float | Sequence[float]) -> np.ndarray:
        array = np.broadcast_to(np.asarray(value, dtype=np.float64), (self.state_dim,))
        if not np.all(np.isfinite(array)):
            raise ConfigError(f"system.{name} must be finite, got {value!r}")
        return array.copy()

    @property
    def state_dim(self) -> int:
        """Number of state components d_x."""
        return len(self.position_indices) + len(self.velocity_indices)

    @property
    def num_steps(self) -> int:
        """Control steps per trial T = trial_duration / dt."""
        return int(round(self.trial_duration / self.dt))

    @property
    def search_steps(self) -> int:
        """Steps the policy search rolls its particles over (the trial's by default)."""
        return self.num_steps

    def sample_initial_state(self, rng: np.random.Generator) -> np.ndarray:
        """Draw x0 ~ p(x0) ``[d_x]`` (see ``initial_distribution``)."""
        if self.initial_distribution == "uniform":
            return self.initial_mean + self.initial_std * rng.uniform(-1.0, 1.0, self.state_dim)
        return self.initial_mean + self.initial_std * rng.standard_normal(self.state_dim)

    def measure(self, state: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """The sensors' reading ``[d_y]`` of ``state`` ``[d_x]`` (see :class:`Sensors`)."""
        return self.sensors.read(state, rng)

    @abstractmethod
    def step(self, state: np.ndarray, action: np.ndarray) -> np.ndarray:
        """Advance the true state ``[d_x]`` by one sample with ``action`` ``[d_u]`` held."""

    def rollout(
        self, controller: Controller, x0: np.ndarray, num_steps: int, rng: np.random.Generator
    ) -> Trajectory:
        """Run ``controller`` in closed loop from ``x0`` for ``num_steps`` samples.

        Raises:
            NonFiniteError: a state, reading or action is NaN or infinite (the message
                names the step and the component); nothing NaN ever reaches the simulator.
        """
        names = self.state_names
        reading_names = tuple(names[i] for i in self.sensors.measured if i < len(names))
        states = np.empty((num_steps + 1, self.state_dim))
        measurements = np.empty((num_steps + 1, self.sensors.reading_dim))
        actions = np.empty((num_steps, self.action_dim))
        states[0] = x0
        require_finite(states[0], "the initial state", 0, names)
        measurements[0] = self.measure(x0, rng)
        require_finite(measurements[0], "the reading", 0, reading_names)
        for t in range(num_steps):
            actions[t] = self.checked_action(controller, measurements[t], t)
            try:
                states[t + 1] = self.step(states[t], actions[t])
            except (NonFiniteError, SimulationError) as error:
                raise type(error)(f"step {t}: {error}") from error
            require_finite(states[t + 1], "the state", t + 1, names)
            measurements[t + 1] = self.measure(states[t + 1], rng)
            require_finite(measurements[t + 1], "the reading", t + 1, reading_names)
        return Trajectory(states=states, measurements=measurements, actions=actions, dt=self.dt)

    def checked_action(self, controller: Controller, reading: np.ndarray, step: int) -> np.ndarray:
        """The controller's action ``[d_u]`` at ``step`` for ``reading``, clipped to ±u_max.

        Raises:
            ValueError: it returned another number of actions than ``action_dim``.
            NonFiniteError: an action is NaN or infinite (named with the step).
        """
        raw = np.asarray(controller(reading, step), dtype=np.float64)
        if raw.size != self.action_dim:
            raise ValueError(
                f"step {step}: the controller returned {raw.size} actions, "
                f"the system takes {self.action_dim}"
            )
        raw = raw.reshape(self.action_dim)
        require_finite(raw, "the action", step)
        return np.clip(raw, -self.u_max, self.u_max)

    def velocity_basis(self, features: torch.Tensor, action: torch.Tensor) -> torch.Tensor:
        """Physically-inspired basis φ of each velocity change, for the SP kernel.

        Args:
            features: ``[..., d_x + n_angles]`` state features x*: the non-angle state
                components in state order, then sin of each angle, then cos of each angle
                (see :class:`mcpilco.models.AngleFeatures`).
            action: ``[..., d_u]`` actions.
        Returns:
            ``[d_q, ..., P]``: row k holds the basis of the k-th velocity's change.
        """
        raise NotImplementedError(
            f"{type(self).__name__} has no physical basis; the SP kernel needs one"
        )

    def known_transition(
        self, states: torch.Tensor, actions: torch.Tensor, coordinates: Sequence[int]
    ) -> tuple[torch.Tensor, torch.Tensor]:
        """Next positions and velocities ``([M, k], [M, k])`` of ``coordinates`` (a subset of
        ``known_coordinates``) from states ``[M, d_x]`` and actions ``[M, d_u]``, in torch
        (differentiable); for models that take them from the system instead of GPs."""
        raise NotImplementedError(f"{type(self).__name__} knows no coordinate's transition")

    def sketch(self, states: np.ndarray) -> np.ndarray | None:
        """A 2-D drawing of each state for viewers: line segments ``[T+1, S, 2, 2]`` (S
        segments from point to point, metres, x right and y up), or None."""
        return None

    def evaluation_cost(self, states: np.ndarray) -> np.ndarray:
        """Task-independent evaluation cost per state ``[T+1]``; NaN where none is defined."""
        return np.full(states.shape[0], np.nan)

    def evaluate(self, trajectory: Trajectory) -> dict[str, float]:
        """Task metrics of a rollout (e.g. evaluation cost, success). Empty by default."""
        return {}


class OdeSystem(MechanicalSystem):
    """A system given by an ODE ẋ = f(x, u), integrated with the action held (ZOH).

    Integration uses scipy's DOP853 with tight tolerances (``rtol``, ``atol``). The work
    per step is bounded: a step that needs more than ``max_evaluations`` evaluations of
    f, or where f is not finite (on which scipy's solver would otherwise loop forever),
    raises an error instead of blocking.
    """

    rtol: float = 1e-10
    atol: float = 1e-10
    max_evaluations: int = 200_000

    @abstractmethod
    def derivatives(self, state: np.ndarray, action: np.ndarray) -> np.ndarray:
        """ẋ ``[d_x]`` at ``state`` ``[d_x]`` under ``action`` ``[d_u]``."""

    def torch_derivatives(self, states: torch.Tensor, actions: torch.Tensor) -> torch.Tensor:
        """ẋ ``[..., d_x]`` of states ``[..., d_x]`` under actions ``[..., d_u]``, in torch
        and differentiable; optional, for optimising a policy on the true equations of
        motion (:class:`mcpilco.models.TrueDynamics`, a diagnostic)."""
        raise NotImplementedError(
            f"{type(self).__name__} has no torch equations of motion (torch_derivatives)"
        )

    def step(self, state: np.ndarray, action: np.ndarray) -> np.ndarray:
        """One sample of the ODE from ``state`` ``[d_x]`` with ``action`` ``[d_u]`` held.

        Raises:
            NonFiniteError: the state, the action or f is NaN or infinite.
            SimulationError: the integrator failed or ran past ``max_evaluations``.
        """
        require_finite(np.asarray(state, dtype=np.float64), "the state to integrate", None)
        require_finite(np.asarray(action, dtype=np.float64), "the action to integrate", None)
        evaluations = 0

        def bounded(_t: float, x: np.ndarray) -> np.ndarray:
            nonlocal evaluations
            evaluations += 1
            if evaluations > self.max_evaluations:
                raise SimulationError(
                    f"{type(self).__name__}: one step of dt={self.dt} s needed more than "
                    f"{self.max_evaluations} evaluations of the dynamics (too stiff?)"
                )
            derivative = np.asarray(self.derivatives(x, action), dtype=np.float64)
            if not np.all(np.isfinite(derivative)):
                raise NonFiniteError(
                    f"the dynamics of {type(self).__name__} returned {derivative.tolist()} "
                    f"at state {x.tolist()} under action {np.asarray(action).tolist()}"
                )
            return derivative

        solution = solve_ivp(
            bounded, (0.0, self.dt), state, method="DOP853", rtol=self.rtol, atol=self.atol
        )
        if solution.status != 0:
            raise SimulationError(
                f"{type(self).__name__}: the integrator failed from state "
                f"{np.asarray(state).tolist()}: {solution.message}"
            )
        return solution.y[:, -1]
