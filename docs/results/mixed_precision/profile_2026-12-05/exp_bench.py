import torch, time
torch.set_num_threads(1)
def bench(f, *a, n=2000):
    for _ in range(50): f(*a)
    t = time.perf_counter()
    for _ in range(n): f(*a)
    return (time.perf_counter() - t) / n * 1e6
for dt in (torch.float64, torch.float32):
    x = -torch.rand(400, 200, dtype=dt) * 5
    out = torch.empty_like(x)
    print(dt, "eager exp 80k:", f"{bench(lambda: torch.exp(x, out=out)):.1f} us")
    xt = -torch.rand(2, 60, 400, dtype=dt) * 5
    print(dt, "eager exp 48k contiguous:", f"{bench(lambda: torch.exp(xt)):.1f} us", "transposed->contig:", f"{bench(lambda: xt.mT.exp().contiguous()):.1f} us")
    f = torch.compile(lambda a: a.exp(), dynamic=False)
    print(dt, "compiled exp 80k:", f"{bench(f, x):.1f} us")
    g = torch.compile(lambda a: a.mT.exp().contiguous(), dynamic=False)
    print(dt, "compiled exp transposed 48k:", f"{bench(g, xt):.1f} us")
