"""Step time with few particles and training points: what a step costs whatever its size
(compiled, float64, one thread). python fixed_cost.py N M"""
import sys, torch
torch.set_num_threads(1)
from runners.bench import time_steps
n, m = int(sys.argv[1]), int(sys.argv[2])
for call in range(2):
    t = time_steps("float64", n, 15, 3, setting=("kernel=se", "model=speed_integration", f"optimizer.num_particles={m}"), compile=True)
    print(f"n={n} M={m} call{call}: {t.median * 1e3:.1f} ms/step")
