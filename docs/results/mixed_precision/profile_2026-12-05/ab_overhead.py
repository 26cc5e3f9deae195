"""A/B/C: inductor Python wrapper (A, current), cpp_wrapper (B), cpp_wrapper + Dynamo
skip_guard_eval_unsafe (C); compiled float64/mixed steps, runners.bench.time_steps."""
import sys, time, torch
torch.set_num_threads(1)
import torch._inductor.config as inductor_config
from runners.bench import time_steps, CARTPOLE

dtype, n, order = sys.argv[1], int(sys.argv[2]), sys.argv[3].split(",")
names = {"A": "python wrapper", "B": "cpp_wrapper", "C": "cpp_wrapper + skip guards"}
for variant in order:
    inductor_config.cpp_wrapper = variant in "BC"
    torch.compiler.set_stance("default", skip_guard_eval_unsafe=variant == "C")
    torch._dynamo.reset()
    start = time.perf_counter()
    t = time_steps(dtype, n, steps=15, warmup=3, compile=True, setting=CARTPOLE)
    print(f"{time.strftime('%H:%M:%S')} {dtype} n={n} {variant} ({names[variant]}): median {t.median*1e3:.1f} ms (call incl. compile {time.perf_counter()-start:.0f} s)", flush=True)
