"""Explicit, independent random streams derived from one seed."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch


@dataclass
class RandomStreams:
    """One numpy generator for the system (noise, x0, exploration) and torch generators
    for policy initialisation and for particle rollouts; same seed → same run."""

    system: np.random.Generator
    policy_init: torch.Generator
    particles: torch.Generator
    reporting: torch.Generator
    """Particles simulated only for logs (kept apart so logging never changes a run)."""

    @classmethod
    def from_seed(cls, seed: int, device: torch.device | str = "cpu") -> RandomStreams:
        sequence = np.random.SeedSequence(seed)
        system_seq, policy_seq, particle_seq, reporting_seq = sequence.spawn(4)
        policy_init = torch.Generator(device="cpu")
        policy_init.manual_seed(int(policy_seq.generate_state(1, np.uint64)[0] >> 1))
        particles = torch.Generator(device=device)
        particles.manual_seed(int(particle_seq.generate_state(1, np.uint64)[0] >> 1))
        reporting = torch.Generator(device=device)
        reporting.manual_seed(int(reporting_seq.generate_state(1, np.uint64)[0] >> 1))
        return cls(np.random.default_rng(system_seq), policy_init, particles, reporting)

    def state(self) -> dict[str, object]:
        """Every generator's state (torch states as uint8 tensors, numpy's as a dict)."""
        return {
            "system": self.system.bit_generator.state,
            "policy_init": self.policy_init.get_state(),
            "particles": self.particles.get_state(),
            "reporting": self.reporting.get_state(),
        }

    def restore(self, state: dict[str, object]) -> None:
        """Continue exactly where :meth:`state` was taken."""
        self.system.bit_generator.state = state["system"]
        self.policy_init.set_state(state["policy_init"])  # type: ignore[arg-type]
        self.particles.set_state(state["particles"])  # type: ignore[arg-type]
        self.reporting.set_state(state["reporting"])  # type: ignore[arg-type]
