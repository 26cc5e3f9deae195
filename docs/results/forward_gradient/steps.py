"""Median step time (compiled, float64, one thread) of the code on PYTHONPATH, twice in one
process (the first call of a process runs slow; the second is the figure).

    python steps.py N TAG [KERNEL]     # N training points; KERNEL se (default) or sp
"""

import sys

import torch

torch.set_num_threads(1)
from runners.bench import time_steps  # noqa: E402

n, tag = int(sys.argv[1]), sys.argv[2]
kernel = sys.argv[3] if len(sys.argv) > 3 else "se"
for call in range(2):
    setting = (f"kernel={kernel}", "model=speed_integration")
    t = time_steps("float64", n, 15, 3, setting=setting, compile=True)
    print(f"{tag} {kernel} n={n} call{call}: {t.median * 1e3:.1f} ms/step (warm-up {t.warmup:.1f} s)")
