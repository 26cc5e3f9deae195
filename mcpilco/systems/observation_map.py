"""Observation → state of a Gymnasium environment: which components are positions,
velocities and angles, declared in config and checked against the observation space."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from mcpilco.errors import ConfigError


@dataclass(frozen=True)
class Component:
    """One state component read off an observation.

    ``index`` reads a component directly; ``cos`` and ``sin`` (both given, no ``index``)
    read an angle θ = atan2(sin, cos) in rad from its cosine and sine, unwrapped along a
    rollout. ``key`` names the entry of a Dict observation (None for a Box); indices are
    into that entry flattened (C order)."""

    index: int | None = None
    cos: int | None = None
    sin: int | None = None
    key: str | None = None

    @property
    def is_angle(self) -> bool:
        return self.cos is not None

    def indices(self) -> tuple[int, ...]:
        return (self.cos, self.sin) if self.is_angle else (self.index,)  # type: ignore[return-value]


def parse_component(name: str, raw: Mapping[str, Any] | Component) -> Component:
    """A component from its YAML form (``{index: 2}``, ``{cos: 0, sin: 1}``, with an
    optional ``key``); a one-line ConfigError naming ``name`` otherwise."""
    if isinstance(raw, Component):
        return raw
    if not isinstance(raw, Mapping) or set(raw) - {"index", "cos", "sin", "key"}:
        raise ConfigError(
            f"{name}={dict(raw) if isinstance(raw, Mapping) else raw!r} must be "
            "{index: i} or {cos: i, sin: j} (each with an optional key: entry)"
        )
    has_index, has_cos, has_sin = ("index" in raw), ("cos" in raw), ("sin" in raw)
    if has_index == (has_cos or has_sin) or has_cos != has_sin:
        raise ConfigError(f"{name}={dict(raw)} needs either index, or both cos and sin")
    values = {k: raw[k] for k in ("index", "cos", "sin") if k in raw}
    for key, value in values.items():
        if isinstance(value, bool) or not isinstance(value, int) or value < 0:
            raise ConfigError(f"{name}.{key}={value!r} must be an index >= 0")
    key = raw.get("key")
    if key is not None and not isinstance(key, str):
        raise ConfigError(f"{name}.key={key!r} must be the name of a Dict observation's entry")
    return Component(**values, key=key)


class ObservationMap:
    """The state ``[q, q̇]`` of observations, per a declaration of its components.

    Args:
        positions: one component per generalised position q_k (angles as cos/sin pairs).
        velocities: one per velocity q̇_k, in the same order (read with ``index``).
        space: the environment's observation space (a gymnasium ``Box`` or a ``Dict`` of
            ``Box``); every component is checked against it here, before any work.
    """

    def __init__(
        self,
        positions: Sequence[Mapping[str, Any] | Component],
        velocities: Sequence[Mapping[str, Any] | Component],
        space: Any,
    ) -> None:
        self.positions = [
            parse_component(f"system.state_map.positions[{k}]", c) for k, c in enumerate(positions)
        ]
        self.velocities = [
            parse_component(f"system.state_map.velocities[{k}]", c)
            for k, c in enumerate(velocities)
        ]
        if not self.positions or len(self.positions) != len(self.velocities):
            raise ConfigError(
                f"system.state_map needs one velocity per position, got {len(self.positions)} "
                f"positions and {len(self.velocities)} velocities"
            )
        for k, component in enumerate(self.velocities):
            if component.is_angle:
                raise ConfigError(
                    f"system.state_map.velocities[{k}] is a velocity: read it with index, "
                    "not cos/sin"
                )
        self.sizes = observation_sizes(space)
        for group, components in (("positions", self.positions), ("velocities", self.velocities)):
            for k, component in enumerate(components):
                self._check(f"system.state_map.{group}[{k}]", component)
        self.angle_indices = tuple(k for k, c in enumerate(self.positions) if c.is_angle)

    def _check(self, name: str, component: Component) -> None:
        if component.key not in self.sizes:
            if component.key is None:
                raise ConfigError(
                    f"{name} needs key: the observation space is a Dict of {sorted(self.sizes)}"
                )
            known = sorted(k for k in self.sizes if k is not None)
            raise ConfigError(
                f"{name}.key={component.key!r} is not an entry of the observation space "
                f"({known if known else 'a Box: give no key'})"
            )
        size = self.sizes[component.key]
        for index in component.indices():
            if index >= size:
                where = f" entry {component.key!r}" if component.key else ""
                raise ConfigError(
                    f"{name} reads component {index} of an observation{where} of {size}"
                )

    @property
    def state_dim(self) -> int:
        return 2 * len(self.positions)

    def _read(self, observation: Any, component: Component) -> np.ndarray:
        """``[2]`` (cos, sin) or ``[1]`` of one observation."""
        entry = observation if component.key is None else observation[component.key]
        flat = np.asarray(entry, dtype=np.float64).reshape(-1)
        return flat[list(component.indices())]

    def record(self, env: Any, observation: Any) -> Any:
        """What a step leaves to read the state from: the observation itself."""
        return observation

    def state(self, record: Any, previous: np.ndarray | None = None) -> np.ndarray:
        """The state ``[d_x]`` of an observation; angles in rad, continuous with the
        ``previous`` state of the rollout (a full turn reads 2π, not 0; see :func:`unwrap`)."""
        row = []
        for component in self.positions:
            values = self._read(record, component)
            row.append(np.arctan2(values[1], values[0]) if component.is_angle else values[0])
        row.extend(self._read(record, c)[0] for c in self.velocities)
        return unwrap(np.asarray(row, dtype=np.float64), previous, self.angle_indices)


def unwrap(state: np.ndarray, previous: np.ndarray | None, angles: Sequence[int]) -> np.ndarray:
    """``state`` ``[d_x]`` with each angle moved by a whole number of turns to lie within
    π of its value in ``previous`` (as ``np.unwrap`` does along a sequence); unchanged
    without a previous state."""
    if previous is None or not angles:
        return state
    columns = list(angles)
    jump = state[columns] - previous[columns]
    state = state.copy()
    state[columns] = previous[columns] + (jump + np.pi) % (2 * np.pi) - np.pi
    return state


def observation_sizes(space: Any) -> dict[str | None, int]:
    """Flattened sizes of a Box (key None) or of each Box entry of a Dict space."""
    from gymnasium import spaces  # the optional extra; checked before this is called

    if isinstance(space, spaces.Box):
        return {None: int(np.prod(space.shape))}
    if isinstance(space, spaces.Dict):
        sizes: dict[str | None, int] = {}
        for key, entry in space.spaces.items():
            if not isinstance(entry, spaces.Box):
                raise ConfigError(
                    f"the observation space's entry {key!r} is {type(entry).__name__}, "
                    "not a Box: give system.state_map.source=simulator or another env"
                )
            sizes[str(key)] = int(np.prod(entry.shape))
        return sizes
    raise ConfigError(
        f"the observation space is {type(space).__name__}: only Box and Dict of Box are read"
    )


class SimulatorStateMap:
    """The state ``[qpos, qvel]`` of a MuJoCo-based environment read off its simulator
    (``env.unwrapped.data``) instead of its observation: exact, and complete where the
    observation leaves components out.

    Args:
        model: the environment's ``mujoco.MjModel``; its joints must have one position
            per velocity (no free or ball joints).
        angles: qpos indices that are angles (None: those of the hinge joints).
    """

    def __init__(self, model: Any, angles: Sequence[int] | None = None) -> None:
        if model.nq != model.nv:
            raise ConfigError(
                f"system.state_map.source=simulator needs one position per velocity; the model "
                f"has nq={model.nq}, nv={model.nv} (a free or ball joint): map the observation"
            )
        self.num_positions = int(model.nq)
        if angles is None:
            hinge = 3  # mujoco.mjtJoint.mjJNT_HINGE
            angles = [
                int(model.jnt_qposadr[j]) for j in range(model.njnt) if model.jnt_type[j] == hinge
            ]
        angles = [int(a) for a in angles]
        if any(not 0 <= a < self.num_positions for a in angles) or len(set(angles)) != len(angles):
            raise ConfigError(
                f"system.state_map.angles={angles} must be distinct qpos indices in "
                f"[0, {self.num_positions})"
            )
        self.angle_indices = tuple(sorted(angles))

    @property
    def state_dim(self) -> int:
        return 2 * self.num_positions

    def record(self, env: Any, observation: Any) -> np.ndarray:
        """``[d_x]``: the simulator's qpos and qvel now (a copy; the observation unused)."""
        data = env.unwrapped.data
        return np.concatenate([np.array(data.qpos, dtype=np.float64), np.array(data.qvel)])

    def state(self, record: np.ndarray, previous: np.ndarray | None = None) -> np.ndarray:
        """The state ``[d_x]`` of a record, angles continuous with ``previous``."""
        state = np.asarray(record, dtype=np.float64).reshape(self.state_dim)
        return unwrap(state, previous, self.angle_indices)
