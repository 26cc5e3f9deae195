import time, torch, numpy as np
torch.set_num_threads(1)
def t(f, reps=60):
    f(); f(); ts=[]
    for _ in range(reps):
        a=time.perf_counter(); f(); ts.append(time.perf_counter()-a)
    return np.median(ts)*1e3
for N in (60,300):
    M=400; G=2
    g=torch.Generator().manual_seed(0)
    A=torch.randn(G,N,N,generator=g,dtype=torch.float64); S=A@A.mT+N*torch.eye(N,dtype=torch.float64)
    L=torch.linalg.cholesky(S).float(); U=L.mT.contiguous()
    K=torch.randn(G,N,M,generator=g)
    fw=lambda: torch.linalg.solve_triangular(U,K.mT,upper=True,left=False)
    bw=lambda: torch.linalg.solve_triangular(L,K.mT,upper=False,left=False)
    print(N, "G=2 forward %.3f backward %.3f ms"%(t(fw),t(bw)), fw().stride(), bw().stride())
