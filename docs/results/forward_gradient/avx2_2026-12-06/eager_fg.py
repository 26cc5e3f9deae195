"""Median eager step time (float64, one thread, SE speed-integration cart-pole, default
forward gradient), twice in one process: python eager_fg.py N"""

import sys

import torch

torch.set_num_threads(1)
from runners.bench import matmul_gflops, time_steps  # noqa: E402

n = int(sys.argv[1])
print(f"float64 GEMM 2000²: {matmul_gflops(2000, 5):.1f} GFLOP/s")
for call in range(2):
    t = time_steps("float64", n, 15, 3, setting=("kernel=se", "model=speed_integration"))
    print(f"default eager n={n} call{call}: {t.median * 1e3:.1f} ms/step")
