"""Derivative-free model structure (DF-MC-PILCO, thesis §4.1, eq. 4.1–4.3)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import torch

from mcpilco.errors import ConfigError
from mcpilco.estimators.base import StateEstimator
from mcpilco.models.base import ModelStructure
from mcpilco.models.features import AngleFeatures

INPUT_KINDS = ("differences", "naive")
DIFFERENCE_UNITS = ("per_step", "per_second")


class DerivativeFree(ModelStructure):
    """GPs predict position changes Δq_t = q_{t+1} − q_t from a history of positions and
    inputs; no velocity is ever estimated.

    On a tracking task (the UR5, §4.3) the policy also reads the position error
    e_t = q_ref,t − q̄_t to the system's reference, from its readings.

    A particle is ``[q_t, q_{t−1}, …, q_{t−m_q}, u_{t−1}, …, u_{t−m_u}]`` (``[M, S]`` with
    S = d_q (m_q+1) + d_u m_u); particles start at rest (q_0 = q_{−1} = …, past inputs 0).
    With ``inputs="differences"`` (eq. 4.2–4.3) the features are
    ``x* = [q_t, Δq_{t−1}, …, Δq_{t−m_q}]`` with Δq_{t−i} = q_{t−i+1} − q_{t−i}; with
    ``"naive"`` they are ``[q_t, …, q_{t−m_q}]``. Angles enter as sin/cos. The policy sees
    x*, the GPs ``[x*, u_t, u_{t−1}, …, u_{t−m_u}]``. With ``difference_units="per_second"``
    the differences in x* are divided by dt (rates in units/s, the scale of the velocities a
    full-state policy reads, so that the policy's initial length-scales and centres suit
    them); ``"per_step"`` feeds Δq as written in eq. 4.2–4.3. The GP targets are Δq either way.

    The model is trained on raw position readings (``estimator=none``). Costs see the
    state ``[q_t, (q_t − q_{t−1}) / dt]`` in the system's layout. In a rollout the policy
    reads the history of simulated noisy readings q̄ = q + e of each particle (thesis §4.1),
    as it reads the real readings on the system.

    With ``known_coordinates`` the coordinates the system moves deterministically (the
    ball-and-plate's position-controlled motors, q_{t+1} = q_t + u_t) get no GP: their next
    positions come from the system's ``known_transition``.

    Args:
        m_q: position memory (≥ 1). m_u: input memory (≥ 0).
        known_coordinates: take the system's known coordinates from it instead of GPs.
        inputs: ``differences`` or ``naive``. difference_units: ``per_step`` or
        ``per_second`` (ignored with ``inputs=naive``). Others: see :class:`ModelStructure`.
    """

    sees_readings = True

    def __init__(
        self,
        *args: object,
        m_q: int = 1,
        m_u: int = 1,
        inputs: str = "differences",
        difference_units: str = "per_step",
        known_coordinates: bool = False,
        **kwargs: object,
    ) -> None:
        super().__init__(*args, **kwargs)  # type: ignore[arg-type]
        if not isinstance(m_q, int) or m_q < 1:
            raise ConfigError(f"model.m_q must be an integer >= 1, got {m_q!r}")
        if not isinstance(m_u, int) or m_u < 0:
            raise ConfigError(f"model.m_u must be an integer >= 0, got {m_u!r}")
        if inputs not in INPUT_KINDS:
            raise ConfigError(f"model.inputs must be one of {list(INPUT_KINDS)}, got {inputs!r}")
        if difference_units not in DIFFERENCE_UNITS:
            raise ConfigError(
                f"model.difference_units must be one of {list(DIFFERENCE_UNITS)}, "
                f"got {difference_units!r}"
            )
        system = self.system
        positions = list(system.position_indices)
        missing = [i for i in positions if i not in system.sensors.measured]
        if missing:
            raise ConfigError(
                f"model=derivative_free needs every position measured; system.measured_indices="
                f"{list(system.sensors.measured)} lacks {missing}"
            )
        self.m_q, self.m_u, self.inputs = m_q, m_u, inputs
        self.known = tuple(system.known_coordinates) if known_coordinates else ()
        if known_coordinates and not self.known:
            raise ConfigError(
                f"model.known_coordinates=true but {type(system).__name__} knows no coordinate"
            )
        self.learned = [k for k in range(len(positions)) if k not in self.known]
        reference = None if self._reference is None else self._reference[:, positions]
        self.register_buffer("_reference_positions", reference, persistent=False)  # [T+1, d_q]
        # columns of [learned, known] back in position order (one gather per step)
        self._learned_known_order = np.argsort(self.learned + list(self.known)).tolist()
        self.difference_scale = 1.0 / system.dt if difference_units == "per_second" else 1.0
        self.num_positions = len(positions)
        self.reading_columns = [list(system.sensors.measured).index(i) for i in positions]
        self.position_features = AngleFeatures(
            self.num_positions, [positions.index(i) for i in system.angle_indices]
        )
        layout = positions + list(system.velocity_indices)
        self.state_order = [layout.index(i) for i in range(system.state_dim)]

    # ------------------------------------------------------------------- layout
    @property
    def output_names(self) -> list[str]:
        return [f"d_q{self.system.position_indices[k]}" for k in self.learned]

    @property
    def _history_size(self) -> int:
        return self.num_positions * (self.m_q + 1)

    def _positions(self, particles: torch.Tensor) -> torch.Tensor:
        """``[..., m_q+1, d_q]``: q_t, q_{t−1}, …"""
        return particles[..., : self._history_size].unflatten(-1, (self.m_q + 1, -1))

    def _past_inputs(self, particles: torch.Tensor) -> torch.Tensor:
        """``[..., d_u m_u]``: u_{t−1}, …, u_{t−m_u}."""
        return particles[..., self._history_size :]

    @property
    def policy_input_dim(self) -> int:
        encoded = self.position_features.dim
        if self.inputs == "differences":
            return encoded + self.m_q * self.num_positions
        return encoded * (self.m_q + 1)

    @property
    def gp_input_dim(self) -> int:
        return self.policy_input_dim + self.system.action_dim * (self.m_u + 1)

    @property
    def policy_angle_columns(self) -> list[tuple[int, int]]:
        """The sin/cos pairs of q_t (and of each older q with ``inputs=naive``)."""
        pairs = self.position_features.angle_columns
        blocks = 1 if self.inputs == "differences" else self.m_q + 1
        width = self.position_features.dim
        return [(s + b * width, c + b * width) for b in range(blocks) for s, c in pairs]

    # ------------------------------------------------------------- ModelStructure
    def encode(self, particles: torch.Tensor) -> torch.Tensor:
        history = self._positions(particles)
        if self.inputs == "naive":
            return self.position_features.encode(history).flatten(-2)
        differences = history[..., :-1, :] - history[..., 1:, :]  # Δq_{t−1}, …, Δq_{t−m_q}
        if self.difference_scale != 1.0:
            differences = differences * self.difference_scale
        current = self.position_features.encode(history[..., 0, :])
        return torch.cat([current, differences.flatten(-2)], dim=-1)

    def gp_inputs(
        self, particles: torch.Tensor, actions: torch.Tensor, encoded: torch.Tensor | None = None
    ) -> torch.Tensor:
        features = self.encode(particles) if encoded is None else encoded
        return torch.cat([features, actions, self._past_inputs(particles)], dim=-1)

    def gp_targets(self, positions: torch.Tensor) -> torch.Tensor:
        return (positions[1:] - positions[:-1])[..., self.learned]

    def transition(
        self, particles: torch.Tensor, actions: torch.Tensor, deltas: torch.Tensor
    ) -> torch.Tensor:
        current = self._positions(particles)[..., 0, :]
        if not self.known:
            return self._shift(particles, current + deltas.T, actions)
        learned = current[..., self.learned] + deltas.T
        known, _ = self.system.known_transition(self.physical_state(particles), actions, self.known)
        following = torch.cat([learned, known], dim=-1)[..., self._learned_known_order]
        return self._shift(particles, following, actions)

    def _shift(
        self, particles: torch.Tensor, positions: torch.Tensor, actions: torch.Tensor
    ) -> torch.Tensor:
        """Push the newest positions ``[M, d_q]`` and the action just applied into the
        history, dropping the oldest."""
        kept_positions = particles[..., : self._history_size - self.num_positions]
        parts = [positions, kept_positions]
        if self.m_u > 0:
            kept_inputs = self._past_inputs(particles)[..., : -self.system.action_dim or None]
            parts += [actions, kept_inputs]
        return torch.cat(parts, dim=-1)

    def initial_particles(self, states: torch.Tensor) -> torch.Tensor:
        """At rest: positions of ``states [M, d_x]`` repeated, past inputs zero."""
        return self._at_rest(states[..., list(self.system.position_indices)])

    def _at_rest(self, positions: torch.Tensor) -> torch.Tensor:
        inputs = positions.new_zeros(*positions.shape[:-1], self.system.action_dim * self.m_u)
        return torch.cat([positions.repeat(1, self.m_q + 1), inputs], dim=-1)

    def physical_state(self, particles: torch.Tensor) -> torch.Tensor:
        history = self._positions(particles)
        velocities = (history[..., 0, :] - history[..., 1, :]) / self.system.dt
        return torch.cat([history[..., 0, :], velocities], dim=-1)[..., self.state_order]

    def policy_inputs(self, particles: torch.Tensor) -> torch.Tensor:
        return self.encode(particles)

    @property
    def tracking_dim(self) -> int:
        """Position errors only: a DF policy reads e_t, no velocity error (thesis §4.3)."""
        return self.num_positions

    def with_tracking_errors(
        self, inputs: torch.Tensor, readings: torch.Tensor, step: int
    ) -> torch.Tensor:
        """Policy inputs ``[M, d_π]`` extended by e_t = q_ref(step) − q̄_t, from the readings
        ``[M, d_y]`` the policy sees (thesis §4.3, the UR5); unchanged without a reference."""
        if self._reference is None:
            return inputs
        positions = readings[..., self.reading_columns]
        return torch.cat([inputs, self._reference_positions[step] - positions], dim=-1)

    def closed_loop_state(
        self,
        previous: torch.Tensor | None,
        estimate: torch.Tensor,
        previous_action: torch.Tensor | None,
    ) -> torch.Tensor:
        """The history particle ``[B, S]`` after the newest readings ``[B, d_y]``."""
        positions = estimate[..., self.reading_columns]
        if previous is None or previous_action is None:
            return self._at_rest(positions)
        return self._shift(previous, positions, previous_action)

    def check_estimator(self, estimator: StateEstimator) -> None:
        if not estimator.is_identity:
            raise ConfigError(
                "model=derivative_free works on raw position readings: use estimator=none, "
                f"got {type(estimator).__name__}"
            )

    def dataset(
        self, states: Sequence[np.ndarray], actions: Sequence[np.ndarray]
    ) -> tuple[torch.Tensor, torch.Tensor]:
        """GP inputs ``[N, D]`` and targets ``[N, d_q]`` from raw readings ``[T+1, d_y]``
        (one array per trajectory; histories before t = 0 padded at rest)."""
        like = self._like()
        inputs, targets = [], []
        for readings, trajectory_actions in zip(states, actions, strict=True):
            positions = torch.as_tensor(np.asarray(readings)[:, self.reading_columns], **like)
            u = torch.as_tensor(trajectory_actions, **like)
            steps = u.shape[0]
            index = {"device": u.device}
            lag = (
                torch.arange(steps, **index)[:, None] - torch.arange(self.m_q + 1, **index)[None, :]
            )
            history = positions[lag.clamp_min(0)].flatten(-2)  # [T, d_q (m_q+1)]
            lag_u = (
                torch.arange(steps, **index)[:, None]
                - torch.arange(1, self.m_u + 1, **index)[None, :]
            )
            past = u[lag_u.clamp_min(0)] * (lag_u >= 0).unsqueeze(-1).to(u.dtype)
            particles = torch.cat([history, past.flatten(-2)], dim=-1)
            inputs.append(self.gp_inputs(particles, u))
            targets.append(self.gp_targets(positions))
        return torch.cat(inputs), torch.cat(targets)

    def output_basis(self, gp_inputs: torch.Tensor) -> torch.Tensor:
        """SP kernel: ``[Δq̂_k / dt, φ_k]`` per output, φ the system's velocity basis at the
        state [q_t, (q_t − q_{t−1}) / dt] read off the GP input (Δq ≈ dt q̇ + dt²/2 q̈)."""
        encoded_size = self.position_features.dim
        current = self.position_features.decode(gp_inputs[..., :encoded_size])
        if self.inputs == "differences":
            step = (
                gp_inputs[..., encoded_size : encoded_size + self.num_positions]
                / self.difference_scale
            )
        else:
            previous = self.position_features.decode(
                gp_inputs[..., encoded_size : 2 * encoded_size]
            )
            step = current - previous
        velocities = step / self.system.dt
        state = torch.cat([current, velocities], dim=-1)[..., self.state_order]
        start = self.policy_input_dim
        action = gp_inputs[..., start : start + self.system.action_dim]
        basis = self.system.velocity_basis(self.features.encode(state), action)  # [d_q, N, P]
        bases = torch.cat([velocities.movedim(-1, 0).unsqueeze(-1), basis], dim=-1)
        return bases[self.learned] if self.known else bases
