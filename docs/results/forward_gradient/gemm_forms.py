import torch, time, sys
torch.set_num_threads(1)
torch.manual_seed(0)
def t(f, reps):
    for _ in range(3): f()
    ts=[]
    for _ in range(reps):
        s=time.perf_counter(); f(); ts.append(time.perf_counter()-s)
    ts.sort(); return ts[len(ts)//2]*1e6
G,M=2,400
for N in (60, 300):
    reps = 200 if N==60 else 60
    S = torch.randn(G,N,N+1,dtype=torch.float64)           # [Γ⁻¹|α] as stored now
    ST = S.mT.contiguous()                                 # [G,N+1,N] row-major
    C = torch.randn(G,N,M,dtype=torch.float64)             # k*ᵀ memory [G,N,M]
    CT = C.mT.contiguous()                                 # [G,M,N]
    fl = 2*G*(N+1)*N*M
    forms = {
     "now: solve.mT @ crossT": lambda: torch.matmul(S.mT, C),
     "rowmajor [N+1,N] @ crossT": lambda: torch.matmul(ST, C),
     "per-G mm": lambda: [torch.mm(S[g].mT, C[g]) for g in range(G)],
     "M side: cross @ solve": lambda: torch.matmul(CT, S),
     "M side: crossT.mT @ solve": lambda: torch.matmul(C.mT, S),
    }
    big = torch.randn(2000,2000,dtype=torch.float64)
    pk = t(lambda: big@big, 5); print(f"square 2000 dgemm {2*2000**3/pk/1e3:.1f} GFLOP/s")
    for k,f in forms.items():
        us=t(f,reps); print(f"N={N} {k:30s} {us:8.1f} us  {fl/us/1e3:5.1f} GFLOP/s")
