"""A/B: SE cross-covariance exp applied before the column-major transpose (in place on the
product's own memory) against the current exp_ on the transposed view; compiled steps."""
import sys, torch
torch.set_num_threads(1)
from mcpilco.kernels import se
from mcpilco.kernels.base import COLUMN_MAJOR_FROM
from runners.bench import time_steps, CARTPOLE
current = se._PreparedCross.covariance

def exp_first(z1, training):
    augmented = torch.cat([z1, z1.square().sum(-1, keepdim=True), torch.ones_like(z1[..., :1])], -1)
    if augmented.shape[-2] < COLUMN_MAJOR_FROM:
        return torch.matmul(augmented, training.mT).exp_()
    return torch.matmul(training, augmented.mT).exp_().mT

dtype, n, order = sys.argv[1], int(sys.argv[2]), sys.argv[3].split(",")
for variant in order:
    se._PreparedCross.covariance = staticmethod(exp_first if variant == "B" else current)
    torch._dynamo.reset()
    t = time_steps(dtype, n, steps=15, warmup=3, compile=True, setting=CARTPOLE)
    print(f"{dtype} n={n} {variant} ({'exp before transpose' if variant == 'B' else 'current'}): median {t.median*1e3:.1f} ms", flush=True)
