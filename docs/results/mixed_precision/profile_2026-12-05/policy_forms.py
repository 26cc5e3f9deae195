"""Policy forward+backward per time step, compiled, float64: the current hand-written
GEMM-expansion node against a direct-difference form left to inductor."""
import torch, time, sys
torch.set_num_threads(1)
from mcpilco.policies.rbf import SquashedRBFPolicy
dt = torch.float64 if sys.argv[1] == "float64" else torch.float32
M, D, B = 400, 5, 200
pol = SquashedRBFPolicy(D, 1, 10.0, B, generator=torch.Generator().manual_seed(0))
g = torch.Generator().manual_seed(1)
x = torch.randn(M, D, dtype=dt, generator=g)
bits = pol.dropout_bits(1, M, g)[0]

def current(x, bits):
    act = pol.prepare(0.25, dtype=None if dt == torch.float64 else dt)
    return act(x, bits)

def direct(x, bits):
    c = pol.centres.to(dt); inv = torch.exp(-pol.log_lengthscale).to(dt); w = pol.weights.to(dt)
    below = torch.tensor(round(0.25 * 256) - 1, dtype=dt)
    keep = bits.to(dt).sub(below).clamp(0.0, 1.0)
    diff = (x * inv).unsqueeze(1) - (c * inv).unsqueeze(0)  # [M, B, D]
    a = torch.exp(-diff.square().sum(-1)) * keep
    return torch.tanh(a @ (w / (10.0 * (1 - 64 / 256)))) * 10.0

def run(f):
    def step(x):
        xx = x.detach().requires_grad_(True)
        for p in pol.parameters(): p.grad = None
        u = f(xx, bits)
        u.sum().backward()
        return u, xx.grad
    return step

def bench(step, n=300):
    for _ in range(20): step(x)
    t = time.perf_counter()
    for _ in range(n): step(x)
    return (time.perf_counter() - t) / n * 1e6

for name, f in (("current", current), ("direct", direct)):
    cf = torch.compile(f, dynamic=False)
    step = run(cf)
    u, gx = step(x); gp = [p.grad.clone() for p in pol.parameters()]
    print(f"{sys.argv[1]} {name}: {bench(step):.0f} us fwd+bwd", flush=True)
    if name == "current": ref = (u.detach(), gx, gp)
    else: print("  max diffs", float((u - ref[0]).abs().max()), float((gx - ref[1]).abs().max()), [float((a - b).abs().max()) for a, b in zip(gp, ref[2])])
