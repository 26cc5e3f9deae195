import sys, torch
torch.set_num_threads(1)
from runners.bench import time_steps, CARTPOLE
dtype, n = sys.argv[1], int(sys.argv[2])
setting = CARTPOLE if len(sys.argv) < 4 else (f"kernel={sys.argv[3]}", "model=speed_integration")
t = time_steps(dtype, n, steps=15, warmup=3, compile=True, setting=setting)
print(f"{dtype} n={n} {setting[0]} median {t.median*1e3:.1f} ms")
