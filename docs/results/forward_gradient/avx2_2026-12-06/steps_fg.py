"""Median step time (compiled, float64, one thread, SE speed-integration cart-pole) of the
default (forward gradient) or the autograd path, twice in one process (the second call is
the figure: the first of a process runs slow).

    python steps_fg.py N default|autograd
"""

import sys

import torch

torch.set_num_threads(1)
from runners.bench import AUTOGRAD, time_steps  # noqa: E402

n, path = int(sys.argv[1]), sys.argv[2]
setting = ("kernel=se", "model=speed_integration") + ((AUTOGRAD,) if path == "autograd" else ())
for call in range(2):
    t = time_steps("float64", n, 15, 3, setting=setting, compile=True)
    print(f"{path} n={n} call{call}: {t.median * 1e3:.1f} ms/step (warm-up {t.warmup:.1f} s)")
