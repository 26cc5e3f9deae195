"""Median step time (compiled, float64, one thread, SE speed-integration cart-pole, the
default forward gradient) with K time steps per compiled call, and the warm-up (compile)
seconds, twice in one process (the second call is the figure).

    python chunks.py N K
"""

import sys

import torch

torch.set_num_threads(1)
from runners.bench import time_steps  # noqa: E402
from runners.process import keep_freed_memory  # noqa: E402

keep_freed_memory()
n, k = int(sys.argv[1]), int(sys.argv[2])
setting = ("kernel=se", "model=speed_integration", f"compile_steps={k}")
for call in range(2):
    t = time_steps("float64", n, 15, 3, setting=setting, compile=True)
    print(f"K={k} n={n} call{call}: {t.median * 1e3:.1f} ms/step (warm-up {t.warmup:.1f} s)")
