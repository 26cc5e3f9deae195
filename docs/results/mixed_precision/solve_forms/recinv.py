import torch, time, numpy as np
torch.set_num_threads(1)
g = torch.Generator().manual_seed(0)
def plan(N, leaf):
    """split points of a recursive halving down to blocks <= leaf"""
    if N <= leaf: return None
    return N // 2
def prep(L64, leaf):
    N = L64.shape[-1]; leaves = {}
    def rec(s, e):
        if e - s <= leaf:
            leaves[s] = torch.linalg.inv(L64[..., s:e, s:e]).float().contiguous(); return
        m = (s + e) // 2; rec(s, m); rec(m, e)
    rec(0, N); return leaves
def solve(L, leaves, K, leaf):
    N = K.shape[-2]; Y = torch.empty_like(K)
    def rec(s, e, rhs):
        if e - s <= leaf:
            torch.matmul(leaves[s], rhs, out=Y[..., s:e, :]); return
        m = (s + e) // 2
        rec(s, m, rhs[..., :m - s, :])
        rec(m, e, torch.baddbmm(rhs[..., m - s:, :], L[..., m:e, s:m], Y[..., s:m, :], alpha=-1) if L.dim()==3 else rhs[..., m-s:, :] - L[..., m:e, s:m] @ Y[..., s:m, :])
    rec(0, N, K); return Y
def timeit(f):
    f(); ts=[]
    for _ in range(30):
        t0=time.perf_counter(); f(); ts.append(time.perf_counter()-t0)
    ts.sort(); return ts[15]*1e3
# ill-conditioned test set
for noise in [1e-2, 1e-3]:
    x = np.linspace(0, 3, 120)[:, None]; xt = x[::3] + 0.004
    gram = np.exp(-((x - x.T) ** 2)) + noise**2 * np.eye(120)
    cross = np.exp(-((xt - x.T) ** 2))
    exp_var = 1 - np.einsum("ij,ji->i", cross, np.linalg.solve(gram, cross.T))
    L64 = torch.linalg.cholesky(torch.as_tensor(gram))[None]; L = L64.float().contiguous()
    K = torch.as_tensor(cross.T).float()[None].contiguous()
    floor = 120**0.5 * np.finfo(np.float32).eps
    y = torch.linalg.solve_triangular(L, K, upper=False)
    v = np.maximum(1 - (y.double()**2).sum(-2)[0].numpy(), floor)
    print(f"noise {noise}: trsm max err/floor {np.abs(v-exp_var).max()/floor:.2f}")
    for leaf in [15, 30, 60]:
        y = solve(L, prep(L64, leaf), K, leaf)
        v = np.maximum(1 - (y.double()**2).sum(-2)[0].numpy(), floor)
        print(f"noise {noise}: leaf {leaf} max err/floor {np.abs(v-exp_var).max()/floor:.2f}")
G, M = 2, 400
for n in [60, 180, 300]:
    X = torch.rand(G, n, 4, dtype=torch.float64, generator=g) * 3
    Gm = torch.exp(-0.5 * torch.cdist(X, X) ** 2) + 1e-4 * torch.eye(n, dtype=torch.float64)
    L64 = torch.linalg.cholesky(Gm); L = L64.float().contiguous(); U = L.mT.contiguous()
    K = torch.exp(-0.5 * torch.cdist(X, torch.rand(G, M, 4, dtype=torch.float64, generator=g) * 3) ** 2).float().contiguous()
    print(f"n={n} MKL {timeit(lambda: torch.linalg.solve_triangular(U, K.mT, upper=True, left=False)):.3f} ms", end="")
    for leaf in [20, 40, 80]:
        W = prep(L64, leaf)
        print(f" | leaf {leaf} {timeit(lambda: solve(L, W, K, leaf)):.3f}", end="")
    print()
