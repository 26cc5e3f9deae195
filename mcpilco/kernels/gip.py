"""Geometrically inspired polynomial kernel (GIP, thesis eq. 5.6; Dalla Libera & Carli).

Rigid-body inverse dynamics τ = B(q) q̈ + C(q, q̇) q̇ + g(q) is a polynomial in q̈ (degree
1), q̇ (degree 2) and q̃ — the sines and cosines of the revolute angles and the prismatic
coordinates — each joint's q̃_j entering with degree at most 2. The GIP kernel spans
exactly such polynomials:

    k(x, x') = (k_P¹(q̈, q̈') + k_P²(q̇, q̇')) · ∏_j k_P²(q̃_j, q̃_j')

with k_Pᵈ(z, z') = ∏_{r=1..d} (σ²_r + zᵀ Σ_r z') the multiplicative polynomial kernel
(Σ_r diagonal), q̃_j = (cos q_j, sin q_j) for a revolute joint and (q_j, 0) for a
prismatic one. The constant σ² of k_P¹ carries the gravity term g(q).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import torch
from torch import nn

from mcpilco.errors import ConfigError
from mcpilco.kernels.base import Kernel, KernelShape, PreparedKernel
from mcpilco.kernels.polynomial import MultiplicativePolynomial


class GeometricPolynomial(Kernel):
    """The GIP kernel on inputs holding joint positions, velocities and accelerations.

    Args:
        shape: outputs and input dimension D.
        positions, velocities, accelerations: input columns of q, q̇, q̈ (n each); by
            default D = 3n ordered [q, q̇, q̈].
        prismatic: indices (into the n joints) of prismatic joints; the others are
            revolute.
        offset: initial σ² of every factor. weight: initial diagonal of every Σ_r.
    """

    def __init__(
        self,
        shape: KernelShape,
        positions: Sequence[int] | None = None,
        velocities: Sequence[int] | None = None,
        accelerations: Sequence[int] | None = None,
        prismatic: Sequence[int] = (),
        offset: float = 1.0,
        weight: float = 1.0,
    ) -> None:
        super().__init__(shape)
        if offset <= 0 or weight <= 0:
            raise ConfigError(
                f"kernel GeometricPolynomial offset and weight must be > 0, got {offset}, {weight}"
            )
        if positions is None and velocities is None and accelerations is None:
            if shape.input_dim % 3:
                raise ConfigError(
                    f"kernel GeometricPolynomial: D={shape.input_dim} is not 3n; give "
                    "positions, velocities and accelerations"
                )
            n = shape.input_dim // 3
            positions, velocities, accelerations = range(n), range(n, 2 * n), range(2 * n, 3 * n)
        if positions is None or velocities is None or accelerations is None:
            raise ConfigError(
                "kernel GeometricPolynomial needs positions, velocities and accelerations "
                "all given or all null"
            )
        columns = [tuple(int(c) for c in dims) for dims in (positions, velocities, accelerations)]
        n = len(columns[0])
        if (
            n == 0
            or any(len(c) != n for c in columns)
            or not all(0 <= c < shape.input_dim for dims in columns for c in dims)
        ):
            raise ConfigError(
                f"kernel GeometricPolynomial: positions/velocities/accelerations must be n "
                f"columns each within D={shape.input_dim}, got {columns}"
            )
        if not all(0 <= j < n for j in prismatic):
            raise ConfigError(
                f"kernel GeometricPolynomial.prismatic={list(prismatic)} not in 0..{n - 1}"
            )
        self.positions = columns[0]
        self.register_buffer("revolute", torch.tensor([j not in set(prismatic) for j in range(n)]))
        self.acceleration_term = MultiplicativePolynomial(
            shape, degree=1, offset=offset, weight=weight, active_dims=columns[2]
        )
        self.velocity_term = MultiplicativePolynomial(
            shape, degree=2, offset=offset, weight=weight, active_dims=columns[1]
        )
        g = shape.num_outputs
        self.log_joint_offset = nn.Parameter(
            torch.full((g, n, 2), math.log(offset), dtype=torch.float64)
        )  # [G, n joints, 2 factors]
        self.log_joint_weight = nn.Parameter(
            torch.full((g, n, 2, 2), math.log(weight), dtype=torch.float64)
        )  # [G, n joints, 2 factors, 2 features]

    def joint_features(self, x: torch.Tensor) -> torch.Tensor:
        """q̃ ``[N, n, 2]``: (cos q_j, sin q_j) for revolute joints, (q_j, 0) for prismatic."""
        q = x[..., list(self.positions)]
        revolute = torch.stack([torch.cos(q), torch.sin(q)], -1)
        prismatic = torch.stack([q, torch.zeros_like(q)], -1)
        return torch.where(self.revolute[:, None], revolute, prismatic)

    def _joint_coefficients(self) -> torch.Tensor:
        """λ ``[G, n, 6]``: joint j's k_P²(q̃_j, q̃_j') = Σ_m λ_m φ_m(q̃_j) φ_m(q̃_j') over the
        monomials φ(a, b) = (1, a, b, a², ab, b²) of q̃_j = (a, b) (the product of its two
        factors (o_r + w_ra aa' + w_rb bb') expanded)."""
        offsets = torch.exp(self.log_joint_offset)  # [G, n, 2 factors]
        weights = torch.exp(self.log_joint_weight)  # [G, n, 2 factors, 2 features]
        o1, o2 = offsets.unbind(-1)
        (w1a, w1b), (w2a, w2b) = weights[..., 0, :].unbind(-1), weights[..., 1, :].unbind(-1)
        return torch.stack(
            [
                o1 * o2,
                o1 * w2a + o2 * w1a,
                o1 * w2b + o2 * w1b,
                w1a * w2a,
                w1a * w2b + w1b * w2a,
                w1b * w2b,
            ],
            -1,
        )

    @staticmethod
    def _monomials(features: torch.Tensor) -> torch.Tensor:
        """φ ``[N, n, 6]`` = (1, a, b, a², ab, b²) of joint features ``[N, n, 2]``."""
        a, b = features.unbind(-1)
        return torch.stack([torch.ones_like(a), a, b, a * a, a * b, b * b], -1)

    def _configuration(self, f1: torch.Tensor, f2: torch.Tensor) -> torch.Tensor:
        """k_Q ``[G, N1, N2]`` from joint features ``[N1, n, 2]``, ``[N2, n, 2]``: joints
        taken two at a time, each pair's k_P² k_P² one matmul over its 36 monomial
        products (exact; about 3.5× faster with its gradient than joint by joint at
        N = 1000, 7 joints — the product of 2n [G, N1, N2] factors is memory-bound)."""
        coefficients = self._joint_coefficients()  # [G, n, 6]
        phi1, phi2 = self._monomials(f1), self._monomials(f2)  # [N, n, 6]
        total: torch.Tensor | None = None
        for j in range(0, f1.shape[1], 2):
            if j + 1 < f1.shape[1]:
                left = (phi1[:, j, :, None] * phi1[:, j + 1, None, :]).flatten(1)  # [N1, 36]
                right = (phi2[:, j, :, None] * phi2[:, j + 1, None, :]).flatten(1)
                weight = (coefficients[:, j, :, None] * coefficients[:, j + 1, None, :]).flatten(1)
            else:
                left, right, weight = phi1[:, j], phi2[:, j], coefficients[:, j]
            block = torch.matmul(left[None] * weight[:, None, :], right.T)  # [G, N1, N2]
            total = block if total is None else total * block
        assert total is not None
        return total

    def forward(self, x1: torch.Tensor, x2: torch.Tensor) -> torch.Tensor:
        motion = self.acceleration_term(x1, x2) + self.velocity_term(x1, x2)
        return motion * self._configuration(self.joint_features(x1), self.joint_features(x2))

    def diag(self, x: torch.Tensor) -> torch.Tensor:
        features = self.joint_features(x).square()  # [N, n, 2]
        weights = torch.exp(self.log_joint_weight)
        factors = torch.einsum("njf,gjrf->gjrn", features, weights)
        factors = factors + torch.exp(self.log_joint_offset)[..., None]
        configuration = factors.flatten(1, 2).prod(dim=1)  # [G, N]
        motion = self.acceleration_term.diag(x) + self.velocity_term.diag(x)
        return motion * configuration

    @property
    def affine_columns(self) -> tuple[int, ...]:
        """Every function of this kernel's space is affine in the accelerations q̈."""
        return self.acceleration_term.active_dims or ()

    def _prepared_configuration(
        self, x2: torch.Tensor
    ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        """The configuration factors' constants at fixed training inputs: joint features
        ``[n, 2 features, N]``, offsets ``[n, G·2, 1]``, weights ``[n, G, 2 factors, 2]``."""
        features2 = self.joint_features(x2).permute(1, 2, 0).contiguous()
        g, n = self.log_joint_offset.shape[:2]
        offsets = torch.exp(self.log_joint_offset).permute(1, 0, 2).reshape(n, g * 2, 1)
        weights = torch.exp(self.log_joint_weight).permute(1, 0, 2, 3)
        return features2, offsets.contiguous(), weights.contiguous()

    def prepare(self, x2: torch.Tensor) -> PreparedKernel:
        cross = self.prepare_cross(x2)
        return lambda x1: (cross(x1), self.diag(x1))

    def prepare_cross(self, x2: torch.Tensor) -> Callable[[torch.Tensor], torch.Tensor]:
        """Cross-covariances to fixed training inputs (predictions). The training joint
        features are laid out ``[n, 2, N]`` once, so the configuration factors of all
        outputs and both factors of a joint come from one batched product per call, and
        test rows sharing one configuration q (e.g. the n + 2 rows of the dynamics
        components, eq. 5.7–5.9) share one k_Q row. (Measured at n = 5000, 7 joints, one
        thread, float64: k_Q of one row 0.51 ms, against 1.0 ms joint by joint.)"""
        features2, offsets, weights = self._prepared_configuration(x2)
        g, n = self.log_joint_offset.shape[:2]
        acceleration = self.acceleration_term.prepare_cross(x2)
        velocity = self.velocity_term.prepare_cross(x2)

        def configuration(x1: torch.Tensor) -> torch.Tensor:
            rows = self.joint_features(x1)  # [M, n, 2]
            m = rows.shape[0]
            coefficients = weights[:, None] * rows.transpose(0, 1)[:, :, None, None, :]
            coefficients = coefficients.reshape(n, m * g * 2, 2)  # [n, M·G·2 factors, 2]
            factors = torch.baddbmm(offsets.repeat(1, m, 1), coefficients, features2)
            return factors.prod(dim=0).view(m, g, 2, -1).prod(dim=2).transpose(0, 1)  # [G, M, N]

        def cross(x1: torch.Tensor) -> torch.Tensor:
            motion = acceleration(x1) + velocity(x1)
            q = x1[:, list(self.positions)]
            shared = bool((q == q[:1]).all())
            return motion * configuration(x1[:1] if shared else x1)

        return cross
