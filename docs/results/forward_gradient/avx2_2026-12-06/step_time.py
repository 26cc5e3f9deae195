"""Median time of one policy-optimisation step (``runners.bench.time_steps``: float64, SE
speed-integration cart-pole, M 400, T 60, n_b 200, one thread, median of 15 after 3),
compiled unless ``--eager``, for the code on PYTHONPATH — twice in one process, the second
call being the figure (the first of a process runs slow). Works with today's code and with
the code before issue 26 (5f5ea0e).

    python step_time.py N TAG [--eager] [--gemm] [--keep-freed-memory] [OVERRIDE ...]

N: training points; TAG: a label for the output line; OVERRIDE: config overrides after
``kernel=se model=speed_integration`` (e.g. ``model.gp.forward_gradient=false``,
``compile_steps=12``, ``optimizer.num_particles=10``); ``--gemm``: print the float64 GEMM
GFLOP/s first; ``--keep-freed-memory``: glibc keeps freed memory, as the runners set it.
"""

import sys

import torch

torch.set_num_threads(1)
n, tag, *rest = sys.argv[1:]
flags = {a for a in rest if a.startswith("--")}
overrides = tuple(a for a in rest if not a.startswith("--"))
if "--keep-freed-memory" in flags:
    from runners.process import keep_freed_memory

    keep_freed_memory()
from runners.bench import matmul_gflops, time_steps  # noqa: E402

if "--gemm" in flags:
    print(f"float64 GEMM 2000²: {matmul_gflops(2000, 5):.1f} GFLOP/s")
setting = ("kernel=se", "model=speed_integration", *overrides)
for call in range(2):
    t = time_steps("float64", int(n), 15, 3, setting=setting, compile="--eager" not in flags)
    print(f"{tag} n={n} call{call}: {t.median * 1e3:.1f} ms/step (warm-up {t.warmup:.1f} s)")
