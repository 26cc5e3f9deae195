import torch, time, math
torch.set_num_threads(1)
g = torch.Generator().manual_seed(0)
G, M = 2, 400
def gram(n, ls=1.0, noise=1e-2, spacing=None):
    if spacing is None:
        X = torch.rand(G, n, 4, dtype=torch.float64, generator=g) * 3
    else:
        X = (torch.arange(n, dtype=torch.float64) * spacing).reshape(1, n, 1).expand(G, n, 1).contiguous()
    d = torch.cdist(X, X) ** 2
    return torch.exp(-0.5 * d / ls**2) + noise * torch.eye(n, dtype=torch.float64), X
def block_lower_solve(Lw, Winv, K, b):
    """L Y = K, L lower [G,N,N] float32, Winv list of inverted diagonal blocks, K [G,N,M]."""
    N = K.shape[-2]; Y = torch.empty_like(K)
    for j, s in enumerate(range(0, N, b)):
        e = min(s + b, N)
        rhs = K[:, s:e] if s == 0 else torch.baddbmm(K[:, s:e], Lw[:, s:e, :s], Y[:, :s], alpha=-1)
        torch.bmm(Winv[j], rhs, out=Y[:, s:e])
    return Y
def prep(L64, b):
    N = L64.shape[-1]
    return [torch.linalg.inv(L64[:, s:min(s+b,N), s:min(s+b,N)]).float().contiguous() for s in range(0, N, b)]
for n in [60, 300]:
    Gm, X = gram(n)
    L64 = torch.linalg.cholesky(Gm); L = L64.float().contiguous()
    Xs = torch.rand(G, M, 4, dtype=torch.float64, generator=g) * 3
    K64 = torch.exp(-0.5 * torch.cdist(X, Xs) ** 2)  # [G, N, M]
    K = K64.float().contiguous()
    ref = torch.linalg.solve_triangular(L64, K64, upper=False)
    var_ref = 1 - (ref**2).sum(-2)
    U = L.mT.contiguous()
    def mkl(): return torch.linalg.solve_triangular(U, K.mT, upper=True, left=False)
    def timeit(f):
        f(); ts=[]
        for _ in range(30):
            t0=time.perf_counter(); f(); ts.append(time.perf_counter()-t0)
        ts.sort(); return ts[15]*1e3
    y = mkl(); err = ((1 - (y.double()**2).sum(-1)) - var_ref).abs().max().item()
    print(f"n={n} MKL trsm {timeit(mkl):.3f} ms  max var err {err:.2e}")
    for b in [25, 50, 75, 100, 150]:
        if b >= n: continue
        W = prep(L64, b)
        f = lambda: block_lower_solve(L, W, K, b)
        y = f(); err = ((1 - (y.double()**2).sum(-2)) - var_ref).abs().max().item()
        print(f"n={n} block-inv b={b:3d} {timeit(f):.3f} ms  max var err {err:.2e}")
