"""Could the exact GP variance be computed from a truncated eigenbasis of the kernel matrix?

Issue 26 item 2 (<= 200 ms per step at n = 300) is out of reach for the exact float64
variance k** - k*^T Gamma^-1 k*: its product is 2 n^2 per particle, output and time step.
With K = U S U^T and Gamma = K + s_n^2 I, dropping the eigenpairs j > r over-estimates the
variance by sum_{j>r} (u_j^T k*)^2 / (s_j + s_n^2) <= k** s_{r+1} / (s_{r+1} + s_n^2) (the
joint prior covariance of the data and x* is positive semi-definite, so sum_j (u_j^T k*)^2
/ s_j <= k**). This prints, for saved GPs at n = 300, the rank r that bound needs for an
error of at most eps * s_n^2 (eps = 0.1, 0.01, 1e-4), and the largest error actually seen
at the training inputs moved by 1 % of their spread (a product of r instead of n columns
would be n / r times cheaper):

    python docs/results/low_rank_variance/spectrum.py RUN_DIR/checkpoints/trial_05 ...
"""

from __future__ import annotations

import sys
from pathlib import Path

import torch

from mcpilco.build import build
from mcpilco.run_storage import RunDirectory
from mcpilco.safe_config import load_run_config

EPSILONS = (1e-1, 1e-2, 1e-4)
RANKS = (100, 150, 200, 250)


def probe(checkpoint: Path) -> str:
    run = checkpoint.parent.parent
    model = build(load_run_config(run)).components.model
    trial = int(checkpoint.name.removeprefix("trial_"))
    model.load_gp(RunDirectory(run).load_checkpoint(trial, "model"))
    gp = model.gp
    inputs = gp.train_inputs
    generator = torch.Generator().manual_seed(0)
    test = inputs + 0.01 * inputs.std(0) * torch.randn(
        inputs.shape, generator=generator, dtype=inputs.dtype
    )
    lines = []
    with torch.no_grad():
        gram = gp.kernel(inputs, inputs)  # [G, N, N]
        cross = gp.kernel(inputs, test)  # [G, N, M]
        prior = gp.kernel.diag(test)  # [G, M]
        for g, noise in enumerate(gp.noise_variance.tolist()):
            values, vectors = torch.linalg.eigh(gram[g])
            values, vectors = values.flip(0).clamp_min(0.0), vectors.flip(1)
            prior_max = float(prior[g].max())
            bound = prior_max * values / (values + noise)  # error if truncated before j
            needed = [int((bound > eps * noise).sum()) for eps in EPSILONS]
            projected = (vectors.T @ cross[g]) ** 2 / (values + noise)[:, None]  # [N, M]
            exact = prior[g] - projected.sum(0)
            seen = [float((projected[r:].sum(0) / noise).max()) for r in RANKS]
            lines.append(
                f"{run.name} {checkpoint.name} output {g}: N {inputs.shape[0]}, "
                f"k**/s_n^2 {prior_max / noise:.3g}, min exact variance / s_n^2 "
                f"{float(exact.min()) / noise:.3g}; rank for bound <= eps s_n^2 "
                + ", ".join(f"eps {e:g}: {r}" for e, r in zip(EPSILONS, needed, strict=True))
                + "; largest error seen / s_n^2 at rank "
                + ", ".join(f"{r}: {s:.2g}" for r, s in zip(RANKS, seen, strict=True))
            )
    return "\n".join(lines)


if __name__ == "__main__":
    torch.set_num_threads(1)
    for path in sys.argv[1:]:
        sys.stdout.write(probe(Path(path)) + "\n")
