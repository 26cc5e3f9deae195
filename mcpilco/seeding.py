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

    @classmethod
    def from_seed(cls, seed: int, device: torch.device | str = "cpu") -> RandomStreams:
        sequence = np.random.SeedSequence(seed)
        system_seq, policy_seq, particle_seq = sequence.spawn(3)
        policy_init = torch.Generator(device="cpu")
        policy_init.manual_seed(int(policy_seq.generate_state(1, np.uint64)[0] >> 1))
        particles = torch.Generator(device=device)
        particles.manual_seed(int(particle_seq.generate_state(1, np.uint64)[0] >> 1))
        return cls(np.random.default_rng(system_seq), policy_init, particles)
