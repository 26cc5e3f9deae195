import torch, time
torch.set_num_threads(1)
g = torch.Generator().manual_seed(0)
n, M, T, G = 300, 400, 60, 2
A = torch.randn(G, n, n, dtype=torch.float64, generator=g); K = A @ A.mT / n + torch.eye(n, dtype=torch.float64)
L = torch.linalg.cholesky(K).float().contiguous()
B = torch.randn(T, G, M, n, generator=g)
def per_step():
    for t in range(T): torch.linalg.solve_triangular(L, B[t], upper=False, left=False)
Bbig = B.permute(1, 0, 2, 3).reshape(G, T * M, n).contiguous()
def big():
    torch.linalg.solve_triangular(L, Bbig, upper=False, left=False)
def chunks(c):
    def f():
        for i in range(0, T, c): torch.linalg.solve_triangular(L, Bbig[:, i*M:(i+c)*M], upper=False, left=False)
    return f
for name, f in [("per step x60", per_step), ("one big", big), ("chunks of 6", chunks(6)), ("chunks of 15", chunks(15)), ("per step x60", per_step), ("one big", big)]:
    f(); ts = []
    for _ in range(5):
        t0 = time.perf_counter(); f(); ts.append(time.perf_counter() - t0)
    ts.sort(); print(f"{name:14s} {ts[2]*1e3:7.1f} ms  ({ts[2]*1e3/T:.3f} ms per step-equivalent)")
