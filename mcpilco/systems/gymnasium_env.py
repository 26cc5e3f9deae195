"""Any registered Gymnasium environment as a system (``system=gymnasium``).

The trial loop's interaction is the environment's own ``reset(seed=…)`` and ``step``: the
start comes from the environment's reset (seeded from the run's system stream, so a run is
reproducible), dt, the action bound and the episode length from the environment. The state
the models see is declared in config (:mod:`mcpilco.systems.observation_map`); the reward
the environment returns is kept with each rollout and summed into ``env_return``.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from mcpilco.checks import require_finite
from mcpilco.errors import ConfigError, SimulationError
from mcpilco.systems.base import Controller, MechanicalSystem
from mcpilco.systems.gym_dynamics import KNOWN as KNOWN_DYNAMICS
from mcpilco.systems.initial_estimate import initial_distribution
from mcpilco.systems.observation_map import ObservationMap, SimulatorStateMap
from mcpilco.trajectory import Trajectory

log = logging.getLogger(__name__)
INSTALL = "pip install -e '.[gym]'"


def make_env(env_id: str, env_kwargs: Mapping[str, Any]) -> Any:
    """``gymnasium.make(env_id, **env_kwargs)``; a one-line ConfigError naming the key when
    the package is missing, the id is unknown or the environment cannot be made."""
    try:
        import gymnasium
    except ImportError:
        raise ConfigError(
            f"system.env_id={env_id!r} needs the gymnasium package, an optional extra: {INSTALL}"
        ) from None
    if not isinstance(env_id, str) or env_id not in gymnasium.registry:
        close = [k for k in gymnasium.registry if str(env_id).split("-")[0].lower() in k.lower()]
        hint = f" (did you mean {', '.join(sorted(close)[:5])}?)" if close else ""
        raise ConfigError(f"system.env_id={env_id!r} is not a registered environment{hint}")
    try:
        return gymnasium.make(env_id, **dict(env_kwargs))
    except gymnasium.error.DependencyNotInstalled as error:
        first = str(error).strip().splitlines()[0]
        raise ConfigError(f"system.env_id={env_id!r}: {first} ({INSTALL})") from None
    except (TypeError, ValueError, gymnasium.error.Error) as error:
        first = str(error).strip().splitlines()[0]
        raise ConfigError(f"system.env_kwargs for {env_id!r} are refused: {first}") from None


class GymnasiumSystem(MechanicalSystem):
    """A Gymnasium environment behind the system interface.

    Args:
        env_id: a registered id (``Pendulum-v1``, ``InvertedPendulum-v5``, ...).
        state_map: ``{positions: [...], velocities: [...]}`` (components of the
            observation, see :class:`ObservationMap`) or ``{source: simulator, angles: null}``
            (a MuJoCo environment's qpos and qvel, see :class:`SimulatorStateMap`; the
            default for a MuJoCo environment when nothing is declared).
        initial: p(x0): ``{distribution: normal|uniform, mean: [...], std: [...]}``, or
            ``{distribution: ..., estimate_from_resets: N, seed: s}`` to estimate it from N
            seeded resets (see :mod:`mcpilco.systems.initial_estimate`; None: a normal
            estimated from 100 resets).
        env_kwargs: keyword arguments of ``gymnasium.make``.
        trial_duration: seconds of interaction per trial (None: the environment's episode,
            ``max_episode_steps`` × dt); at most the episode.
        search_duration: seconds the policy search rolls its particles over (None: the
            trial's).
        measurement_noise_std: sensor noise added to the state read off the environment
            (0: exact readings).
        state_names: labels of the state components (``q0``, ..., ``dq0``, ... if None).
        dt: the sampling time, for environments that do not say (``env.unwrapped.dt``).
        u_max: the action bound (None: the environment's; a smaller one narrows it).
    """

    exact_readings_allowed = True

    def __init__(
        self,
        env_id: str,
        state_map: Mapping[str, Any] | None = None,
        initial: Mapping[str, Any] | None = None,
        env_kwargs: Mapping[str, Any] | None = None,
        trial_duration: float | None = None,
        search_duration: float | None = None,
        measurement_noise_std: float | Sequence[float] = 0.0,
        measured_indices: Sequence[int] | None = None,
        quantization: float | Sequence[float] | None = None,
        state_names: Sequence[str] | None = None,
        dt: float | None = None,
        u_max: float | None = None,
    ) -> None:
        self.env_id = env_id
        self.env = make_env(env_id, env_kwargs or {})
        self.reader = self._state_reader(dict(state_map or {}))
        count = self.reader.state_dim // 2
        self.position_indices = tuple(range(count))
        self.velocity_indices = tuple(range(count, 2 * count))
        self.angle_indices = tuple(self.reader.angle_indices)
        self.state_names = tuple(
            state_names or [f"q{k}" for k in range(count)] + [f"dq{k}" for k in range(count)]
        )
        if len(self.state_names) != 2 * count:
            raise ConfigError(f"system.state_names needs {2 * count} names, got {state_names}")
        self.action_dim, bound = self._action_bound()
        if u_max is not None and not 0 < float(u_max) <= bound:
            raise ConfigError(f"system.u_max={u_max} must be in (0, {bound}], {env_id}'s bound")
        u_max = bound if u_max is None else float(u_max)
        sample_dt = self._sample_time(dt)
        episode_steps = self.env.spec.max_episode_steps if self.env.spec else None
        if trial_duration is None:
            if episode_steps is None:
                raise ConfigError(
                    f"system.trial_duration is needed: {env_id} sets no episode length"
                )
            trial_duration = episode_steps * sample_dt
        initial = {"estimate_from_resets": 100} if initial is None else initial
        self.initial = initial_distribution(dict(initial), 2 * count, self._reset_state)
        super().__init__(
            dt=sample_dt,
            trial_duration=trial_duration,
            u_max=u_max,
            measurement_noise_std=measurement_noise_std,
            initial_mean=self.initial.mean,
            initial_std=self.initial.std,
            measured_indices=measured_indices,
            quantization=quantization,
            initial_distribution=self.initial.distribution,
        )
        if episode_steps is not None and self.num_steps > episode_steps:
            raise ConfigError(
                f"system.trial_duration={trial_duration} is {self.num_steps} steps, longer than "
                f"{env_id}'s episode of {episode_steps}"
            )
        self._search_steps = self.num_steps
        if search_duration is not None:
            steps = float(search_duration) / self.dt
            if not search_duration > 0 or abs(steps - round(steps)) > 1e-6:
                raise ConfigError(
                    f"system.search_duration={search_duration} must be a whole number > 0 of "
                    f"dt={self.dt} steps"
                )
            self._search_steps = int(round(steps))
        self._pending: tuple[Any, np.ndarray] | None = None

    def _state_reader(self, state_map: dict[str, Any]) -> ObservationMap | SimulatorStateMap:
        declared = bool(state_map)
        source = state_map.pop("source", "observation" if declared else None)
        if source is None:  # nothing declared: a MuJoCo environment's simulator state
            model = getattr(self.env.unwrapped, "model", None)
            source = "simulator" if hasattr(model, "nq") else ""
            if not source:
                raise ConfigError(
                    f"system.state_map is needed for {self.env_id}: declare its positions and "
                    "velocities (docs/gymnasium.md)"
                )
        if source == "simulator":
            unknown = set(state_map) - {"angles"}
            model = getattr(self.env.unwrapped, "model", None)
            if unknown or model is None or not hasattr(model, "nq"):
                why = f"unknown keys {sorted(unknown)}" if unknown else "not a MuJoCo environment"
                raise ConfigError(f"system.state_map.source=simulator: {why}")
            return SimulatorStateMap(model, state_map.get("angles"))
        if source != "observation":
            raise ConfigError(
                f"system.state_map.source={source!r} must be observation or simulator"
            )
        unknown = set(state_map) - {"positions", "velocities"}
        if unknown:
            raise ConfigError(f"system.state_map has unknown keys {sorted(unknown)}")
        return ObservationMap(
            state_map.get("positions") or [],
            state_map.get("velocities") or [],
            self.env.observation_space,
        )

    def _action_bound(self) -> tuple[int, float]:
        from gymnasium import spaces

        space = self.env.action_space
        if not isinstance(space, spaces.Box) or len(space.shape) != 1:
            raise ConfigError(
                f"system.env_id={self.env_id!r}: the actions are {space}, not a 1-D Box"
            )
        low, high = np.asarray(space.low, float), np.asarray(space.high, float)
        if not (
            np.all(np.isfinite(high)) and np.allclose(low, -high) and np.allclose(high, high[0])
        ):
            raise ConfigError(
                f"system.env_id={self.env_id!r}: action bounds [{low.tolist()}, {high.tolist()}] "
                "are not one symmetric finite bound (|u| <= u_max) for every component"
            )
        return int(space.shape[0]), float(high[0])

    def _sample_time(self, dt: float | None) -> float:
        own = getattr(self.env.unwrapped, "dt", None)
        if dt is None and own is None:
            raise ConfigError(f"system.dt is needed: {self.env_id} does not say its sampling time")
        if dt is not None and own is not None and abs(float(dt) - float(own)) > 1e-12:
            raise ConfigError(f"system.dt={dt} differs from {self.env_id}'s own dt={own}")
        return float(own if dt is None else dt)

    def _reset_state(self, seed: int) -> np.ndarray:
        """The state ``[d_x]`` the environment starts in after ``reset(seed=seed)``."""
        observation, _ = self.env.reset(seed=int(seed))
        return self.reader.state(self.reader.record(self.env, observation))

    @property
    def search_steps(self) -> int:
        return self._search_steps

    @property
    def episode_steps(self) -> int | None:
        """The environment's episode length (``max_episode_steps``; None: unlimited)."""
        return self.env.spec.max_episode_steps if self.env.spec else None

    def sample_initial_state(self, rng: np.random.Generator) -> np.ndarray:
        """Reset the environment with a seed drawn from ``rng``; its start ``[d_x]``.
        (The start is the environment's: :meth:`rollout` runs from it.)"""
        seed = int(rng.integers(0, 2**31 - 1))
        state = self._reset_state(seed)
        self._pending = (seed, state)
        return state.copy()

    def step(self, state: np.ndarray, action: np.ndarray) -> np.ndarray:
        raise SimulationError(
            f"{self.env_id} cannot be stepped from a given state: run it with rollout()"
        )

    def rollout(
        self, controller: Controller, x0: np.ndarray, num_steps: int, rng: np.random.Generator
    ) -> Trajectory:
        """Run ``controller`` on the environment from its last reset (whose state ``x0``
        must be) for ``num_steps`` steps, or until the episode terminates."""
        if self._pending is None or not np.array_equal(self._pending[1], x0):
            raise SimulationError(
                f"{self.env_id} starts where its reset puts it: call sample_initial_state() "
                "and roll out from the state it returns"
            )
        self._pending = None
        states, readings = [np.asarray(x0, dtype=np.float64)], [self.measure(x0, rng)]
        actions: list[np.ndarray] = []
        rewards: list[float] = []
        dtype = self.env.action_space.dtype
        for t in range(num_steps):
            action = self.checked_action(controller, readings[-1], t)
            observation, reward, terminated, truncated, _ = self.env.step(action.astype(dtype))
            state = self.reader.state(self.reader.record(self.env, observation), states[-1])
            require_finite(state, "the state", t + 1, self.state_names)
            actions.append(action)
            rewards.append(float(reward))
            states.append(state)
            readings.append(self.measure(state, rng))
            if terminated or truncated:
                break
        return Trajectory(
            states=np.asarray(states),
            measurements=np.asarray(readings),
            actions=np.asarray(actions).reshape(len(actions), self.action_dim),
            dt=self.dt,
            rewards=np.asarray(rewards),
        )

    def evaluate(self, trajectory: Trajectory) -> dict[str, float]:
        """``env_return`` (the environment's rewards summed), ``env_steps`` and whether the
        episode ended before the trial (``terminated``)."""
        rewards = trajectory.rewards if trajectory.rewards is not None else np.zeros(0)
        return {
            "env_return": float(np.sum(rewards)),
            "env_steps": int(trajectory.num_steps),
            "terminated": bool(trajectory.num_steps < self.num_steps),
        }

    def torch_step(self, states: Any, actions: Any) -> Any:
        """Next states ``[..., d_x]`` of states ``[..., d_x]`` under actions ``[..., d_u]`` by
        the environment's own equations in torch, for the environments whose equations
        :mod:`mcpilco.systems.gym_dynamics` knows (the true-dynamics diagnostic)."""
        if self.env_id not in KNOWN_DYNAMICS or not isinstance(self.reader, ObservationMap):
            raise NotImplementedError(
                f"{self.env_id}: no torch equations of motion are known "
                f"(mcpilco/systems/gym_dynamics.py knows {sorted(KNOWN_DYNAMICS)})"
            )
        if not hasattr(self, "_torch_step"):
            self._torch_step = KNOWN_DYNAMICS[self.env_id](self.env)
        return self._torch_step(states, actions)

    def describe(self) -> dict[str, Any]:
        """What the run directory records of this system: the environment and p(x0)."""
        return {"env_id": self.env_id, "dt": self.dt, "u_max": self.u_max,
                "trial_steps": self.num_steps, "search_steps": self.search_steps,
                "initial": self.initial.as_dict()}  # fmt: skip
