"""The model-structure interface shared by full-state, speed-integration and DF models."""

from __future__ import annotations

import copy
import time
from abc import ABC, abstractmethod
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import torch
from torch import nn

from mcpilco.errors import ConfigError
from mcpilco.estimators.base import StateEstimator
from mcpilco.extension import ExtensionPoint
from mcpilco.gp.exact import ExactGP
from mcpilco.gp.fit import MarginalLikelihoodFit
from mcpilco.gp.reduction import check_reduction, reduce_dataset
from mcpilco.kernels.base import KernelFactory, KernelShape
from mcpilco.models.features import AngleFeatures
from mcpilco.systems.base import MechanicalSystem

GPFactory = Callable[..., ExactGP]


@dataclass(frozen=True)
class FitReport:
    """What one model fit did: data size before/after reduction, final −log p/N, seconds."""

    num_samples: int
    num_kept: int
    negative_log_likelihood: float
    seconds: float


class ModelStructure(ExtensionPoint, nn.Module, ABC):
    """A learned one-step model: particles ``[M, S]`` × actions ``[M, d_u]`` → particles.

    A *particle* is whatever the structure propagates (the state ``[M, d_x]`` for full-state
    and speed-integration; a history of positions and inputs for derivative-free models).
    Subclasses define the GP inputs/targets and the transition; fitting, prediction and
    sampling with the reparameterisation trick live here.

    Args:
        system: the plant (dimensions, dt, angles, physical basis).
        kernel: kernel factory (from the ``kernel`` config group).
        gp: GP factory, ``gp(kernel=..., output_names=...)``.
        fit: hyper-parameter training.
        reduction_threshold: β of §2.3.3; None disables reduction.
        reduction_mode: ``absolute`` (β in target units) or ``relative`` (β in units of each
            output's trained noise std, the reference code's SoD mode).
    """

    fits_gps: bool = True
    """False for a structure that learns nothing (its fit reports no likelihood, NaN)."""

    def __init__(
        self,
        system: MechanicalSystem,
        kernel: KernelFactory,
        gp: GPFactory,
        fit: MarginalLikelihoodFit,
        reduction_threshold: float | None = None,
        reduction_mode: str = "absolute",
    ) -> None:
        super().__init__()
        check_reduction(reduction_threshold, reduction_mode)
        self.system = system
        self.kernel_factory = kernel
        self.gp_factory = gp
        self.fitter = fit
        self.reduction_threshold = reduction_threshold
        self.reduction_mode = reduction_mode
        self.features = AngleFeatures(system.state_dim, system.angle_indices)
        self.gp: ExactGP | None = None
        # Follows .to(dtype/device) of the module; tells where new tensors go.
        self.register_buffer("_dtype_probe", torch.zeros((), dtype=torch.float64), persistent=False)
        reference = system.reference_states
        self.register_buffer(
            "_reference",
            None if reference is None else torch.as_tensor(reference, dtype=torch.float64),
            persistent=False,
        )

    # ----------------------------------------------------------------- structure-specific
    @property
    @abstractmethod
    def output_names(self) -> list[str]:
        """One name per GP output (G of them)."""

    @property
    def gp_input_dim(self) -> int:
        """D: the GP input is [x*, u]."""
        return self.features.dim + self.system.action_dim

    @property
    def policy_input_dim(self) -> int:
        """Size of :meth:`policy_inputs` (before tracking errors)."""
        return self.features.dim

    @property
    def policy_input_size(self) -> int:
        """What the policy reads: :meth:`policy_inputs`, plus the error to the reference
        state (``d_x``) on a tracking task (:meth:`with_tracking_errors`)."""
        tracking = 0 if self._reference is None else self.tracking_dim
        return self.policy_input_dim + tracking

    @property
    def tracking_dim(self) -> int:
        """Tracking-error columns the policy reads on a tracking task: the whole state's."""
        return self.system.state_dim

    @property
    def policy_angle_columns(self) -> list[tuple[int, int]]:
        """(sin θ, cos θ) column pairs of the policy input, one per angle it reads."""
        return self.features.angle_columns

    def with_tracking_errors(
        self, inputs: torch.Tensor, states: torch.Tensor, step: int
    ) -> torch.Tensor:
        """Policy inputs ``[M, d_π]`` extended by x_ref(step) − x for states ``[M, d_x]`` on a
        tracking task (thesis §2.6.3: the UR5 policy reads e and ė); unchanged otherwise."""
        if self._reference is None:
            return inputs
        return torch.cat([inputs, self._reference[step] - states], dim=-1)

    def encode(self, particles: torch.Tensor) -> torch.Tensor:
        """Features of particles ``[M, S]`` that GP and policy inputs are built from
        (x* for full-state and speed-integration models)."""
        return self.features.encode(particles)

    def gp_inputs(
        self, particles: torch.Tensor, actions: torch.Tensor, encoded: torch.Tensor | None = None
    ) -> torch.Tensor:
        """GP inputs ``[M, D]`` = [x*, u] of particles ``[M, S]`` and actions ``[M, d_u]``;
        ``encoded`` is ``self.encode(particles)`` when the caller has it already."""
        features = self.encode(particles) if encoded is None else encoded
        return torch.cat([features, actions], dim=-1)

    @abstractmethod
    def gp_targets(self, states: torch.Tensor) -> torch.Tensor:
        """Targets ``[T, G]`` of one trajectory of (estimated) states ``[T+1, d_x]``."""

    @abstractmethod
    def transition(
        self, particles: torch.Tensor, actions: torch.Tensor, deltas: torch.Tensor
    ) -> torch.Tensor:
        """Next particles ``[M, S]`` from sampled GP outputs ``deltas [G, M]``."""

    def initial_particles(self, states: torch.Tensor) -> torch.Tensor:
        """Particles ``[M, S]`` for initial states ``[M, d_x]``."""
        return states

    def physical_state(self, particles: torch.Tensor) -> torch.Tensor:
        """The state ``[M, d_x]`` a cost is computed on."""
        return particles

    def policy_inputs(self, states: torch.Tensor) -> torch.Tensor:
        """Policy input ``[..., d_π]`` from (estimated) states ``[..., d_x]``."""
        return self.features.encode(states)

    def policy_inputs_from_encoded(self, encoded: torch.Tensor) -> torch.Tensor:
        """Policy input of a particle from its :meth:`encode` features (the policy sees the
        particle itself, e.g. with full-state measurement)."""
        return encoded

    def output_basis(self, gp_inputs: torch.Tensor) -> torch.Tensor:
        """Physically-inspired features ``[G, N, P]`` of GP inputs ``[N, D]`` (SP kernel)."""
        raise NotImplementedError

    sees_readings: bool = False
    """True when the policy acts on (histories of) raw readings rather than on states, so a
    rollout simulates the sensors even with the identity estimator (derivative-free)."""

    def check_estimator(self, estimator: StateEstimator) -> None:
        """Refuse an estimator this structure cannot learn from (before any work): a
        state-based model needs full states, so raw readings must hold every component."""
        if estimator.is_identity and not self.system.sensors.measures_everything:
            raise ConfigError(
                "estimator=none needs the full state measured, but system.measured_indices="
                f"{list(self.system.sensors.measured)}: pick a velocity estimator "
                "(estimator=difference|lowpass|zero_phase|kalman) or model=derivative_free"
            )

    def closed_loop_state(
        self,
        previous: torch.Tensor | None,
        estimate: torch.Tensor,
        previous_action: torch.Tensor | None,
    ) -> torch.Tensor:
        """What :meth:`policy_inputs` reads in closed loop on the system, from the online
        estimate ``[B, ·]`` (and, for structures with memory, the previous one and the last
        action ``[B, d_u]``). State-based structures: the estimate itself."""
        return estimate

    # ------------------------------------------------------------------------ shared
    def dataset(
        self, states: Sequence[np.ndarray], actions: Sequence[np.ndarray]
    ) -> tuple[torch.Tensor, torch.Tensor]:
        """Stack GP inputs ``[N, D]`` and targets ``[N, G]`` of several trajectories."""
        inputs, targets = [], []
        like = self._like()
        for trajectory_states, trajectory_actions in zip(states, actions, strict=True):
            x = torch.as_tensor(trajectory_states, **like)
            u = torch.as_tensor(trajectory_actions, **like)
            inputs.append(self.gp_inputs(x[:-1], u))
            targets.append(self.gp_targets(x))
        return torch.cat(inputs), torch.cat(targets)

    def _like(self) -> dict[str, torch.dtype | torch.device]:
        return {"dtype": self._dtype_probe.dtype, "device": self._dtype_probe.device}

    def new_gp(self) -> ExactGP:
        """A GP with freshly initialised hyper-parameters, in this model's dtype/device."""
        shape = KernelShape(self.num_outputs, self.gp_input_dim, self._basis_or_none())
        gp = self.gp_factory(kernel=self.kernel_factory(shape), output_names=self.output_names)
        return gp.to(**self._like())

    def _basis_or_none(self) -> Callable[[torch.Tensor], torch.Tensor] | None:
        try:
            probe = torch.zeros(
                1, self.gp_input_dim, dtype=torch.float64, device=self._like()["device"]
            )
            self.output_basis(probe)
        except NotImplementedError:
            return None
        return self.output_basis

    @property
    def num_outputs(self) -> int:
        return len(self.output_names)

    def fit(self, states: Sequence[np.ndarray], actions: Sequence[np.ndarray]) -> FitReport:
        """Re-initialise the GPs and train them on all trajectories so far."""
        start = time.perf_counter()
        inputs, targets = self.dataset(states, actions)
        self.gp = self.new_gp()
        self.gp.set_data(inputs, targets)
        nll = self.fitter(self.gp)
        if self.reduction_threshold is not None:
            reduce_dataset(self.gp, self.reduction_threshold, self.reduction_mode)
        return FitReport(
            num_samples=int(inputs.shape[0]),
            num_kept=int(self.gp.train_inputs.shape[0]),
            negative_log_likelihood=nll,
            seconds=time.perf_counter() - start,
        )

    def step(
        self,
        particles: torch.Tensor,
        actions: torch.Tensor,
        noise: torch.Tensor,
        encoded: torch.Tensor | None = None,
    ) -> torch.Tensor:
        """Sample next particles with the reparameterisation trick.

        Args:
            particles: ``[M, S]``. actions: ``[M, d_u]``.
            noise: standard normal ``[G, M]``.
            encoded: ``self.encode(particles)`` if already computed.
        """
        if self.gp is None:
            raise RuntimeError("model.step called before model.fit")
        deltas = self.gp.sample(self.gp_inputs(particles, actions, encoded), noise)
        return self.transition(particles, actions, deltas)

    def in_dtype(self, dtype: torch.dtype) -> ModelStructure:
        """This model for particles in ``dtype`` (a float32 rollout of a float64 model):
        ``self`` when it is in ``dtype`` already, else a shallow twin whose constant buffers
        (transition maps, feature selections, references) are cast and whose GP is this
        model's own (its predictions follow their inputs' dtype, from the float64
        factorisation: :meth:`ExactGP.sample`). Fitting and checkpoints stay with ``self``;
        a twin is stale after the next :meth:`fit` (its ``gp`` is the old one)."""
        if dtype == self._dtype_probe.dtype:
            return self
        twin = copy.copy(self)
        twin._buffers = {  # a new dict: the twin's buffers are its own
            name: b.to(dtype) if b is not None and b.is_floating_point() else b
            for name, b in self._buffers.items()
        }
        twin._modules = {
            name: module
            if isinstance(module, ExactGP) or module is None
            else copy.deepcopy(module).to(dtype)
            for name, module in self._modules.items()
        }
        return twin

    def checkpoint(self) -> dict[str, torch.Tensor]:
        """The fitted model's state to save after a trial (:meth:`load_gp` restores it)."""
        if self.gp is None:
            raise RuntimeError("model.checkpoint called before model.fit")
        return self.gp.state_dict()

    def hyperparameters(self) -> dict[str, list[float]]:
        """The fitted GPs' hyper-parameters by name, for logs."""
        if self.gp is None:
            raise RuntimeError("model.hyperparameters called before model.fit")
        return self.gp.hyperparameters()

    def load_gp(self, state: dict[str, torch.Tensor]) -> None:
        """Restore a fitted GP from :meth:`checkpoint` output (a saved checkpoint)."""
        self.gp = self.new_gp()
        self.gp.set_data(state["train_inputs"], state["train_targets"])
        self.gp.load_state_dict(state)
        self.gp.precompute()
