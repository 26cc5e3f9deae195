"""Median step time (compiled, float64, one thread, SE speed-integration cart-pole, each
tree's own default) of the code on PYTHONPATH, twice in one process (the second call is
the figure). Works with the code before issue 26 (5f5ea0e) and today's.

    python before_after.py N TAG
"""

import sys

import torch

torch.set_num_threads(1)
from runners.bench import time_steps  # noqa: E402

n, tag = int(sys.argv[1]), sys.argv[2]
for call in range(2):
    t = time_steps("float64", n, 15, 3, setting=("kernel=se", "model=speed_integration"), compile=True)
    print(f"{tag} n={n} call{call}: {t.median * 1e3:.1f} ms/step")
