import time, torch, numpy as np, scipy.linalg.blas as B, os
torch.set_num_threads(1)
def t(f, reps=40):
    f(); f()
    ts=[]
    for _ in range(reps):
        a=time.perf_counter(); f(); ts.append(time.perf_counter()-a)
    return np.median(ts)*1e3
for N in (60,300):
    M=400
    g=torch.Generator().manual_seed(0)
    A=torch.randn(N,N,generator=g,dtype=torch.float64); S=A@A.T+N*torch.eye(N,dtype=torch.float64)
    L=torch.linalg.cholesky(S).float(); K=torch.randn(N,M,generator=g)
    LU=L.T.contiguous()
    f1=lambda: torch.linalg.solve_triangular(L,K,upper=False)
    f2=lambda: torch.linalg.solve_triangular(LU,K,upper=True)
    f3=lambda: L@K
    Ln=np.asfortranarray(L.numpy()); Kn=np.asfortranarray(K.numpy())
    f4=lambda: B.strsm(1.0,Ln,Kn,lower=1)
    Kc=np.ascontiguousarray(K.numpy())
    # row-major K: solve X^T = K^T L^-T  -> strsm side=1 on K^T (fortran view of C array)
    f5=lambda: B.strsm(1.0,Ln,Kc.T,side=1,lower=1,trans_a=1)
    print(N, "torch trsm L %.3f  torch trsm U %.3f  torch gemm %.3f  openblas strsm %.3f  openblas right %.3f ms"%(t(f1),t(f2),t(f3),t(f4),t(f5)))
    x1=f1().numpy(); x4=f4(); print(" agree", np.abs(x1-x4).max()/np.abs(x1).max(), np.abs(x1-f5().T).max()/np.abs(x1).max())
