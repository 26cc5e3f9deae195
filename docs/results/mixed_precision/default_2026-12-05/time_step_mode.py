import sys, torch
torch.set_num_threads(1)
from runners.bench import time_steps
dtype, n, mode = sys.argv[1], int(sys.argv[2]), sys.argv[3]
t = time_steps(dtype, n, steps=15, warmup=3, compile=(mode == "compiled"))
print(f"{dtype} n={n} {mode} median {t.median*1e3:.1f} ms")
