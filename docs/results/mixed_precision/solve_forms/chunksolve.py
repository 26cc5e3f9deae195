import torch, time
torch.set_num_threads(1)
g = torch.Generator().manual_seed(0)
n, M, T, G = 300, 400, 60, 2
A = torch.randn(G, n, n, dtype=torch.float64, generator=g); K = A @ A.mT / n + torch.eye(n, dtype=torch.float64)
L = torch.linalg.cholesky(K).float().contiguous(); U = L.mT.contiguous()
B = torch.randn(T, G, M, n, generator=g)   # rows: k* row-major [G, M, n]
Bc = B.mT.contiguous().mT                   # column-major storage as the step has it
def run(c, X, F, upper):
    def f():
        for t in range(T):
            for i in range(0, M, c): torch.linalg.solve_triangular(F, X[t][:, i:i+c], upper=upper, left=False)
    return f
for rep in range(2):
  for c in [400, 200, 100, 50]:
    for lab, X in [("row", B), ("col", Bc)]:
      f = run(c, X, U, True); f(); ts = []
      for _ in range(5):
          t0 = time.perf_counter(); f(); ts.append(time.perf_counter() - t0)
      ts.sort(); print(f"chunk {c:3d} {lab} upper: {ts[2]*1e3/T:.3f} ms per step")
