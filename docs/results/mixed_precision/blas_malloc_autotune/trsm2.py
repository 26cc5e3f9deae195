import time, torch, numpy as np, scipy.linalg.blas as B
torch.set_num_threads(1)
def t(f, reps=60):
    f(); f(); ts=[]
    for _ in range(reps):
        a=time.perf_counter(); f(); ts.append(time.perf_counter()-a)
    return np.median(ts)*1e3
for N in (60,180,300):
    M=400
    g=torch.Generator().manual_seed(0)
    A=torch.randn(N,N,generator=g,dtype=torch.float64); S=A@A.T+N*torch.eye(N,dtype=torch.float64)
    L=torch.linalg.cholesky(S).float().numpy(); U=np.ascontiguousarray(L.T)
    K=np.ascontiguousarray(torch.randn(N,M,generator=g).numpy())  # B^T, C-order
    # X L = B : a=U.T (=L, F), lower=1, trans=0 ;  a=L.T (=L^T F), lower=0, trans=1
    v1=lambda: B.strsm(1.0,U.T,K.T.copy(order='F'),side=1,lower=1,trans_a=0,overwrite_b=1)
    v2=lambda: B.strsm(1.0,L.T,K.T.copy(order='F'),side=1,lower=0,trans_a=1,overwrite_b=1)
    # X L^T = B: a=U.T (=L), lower=1, trans=1 ; a=L.T(=L^T, upper) trans=0
    v3=lambda: B.strsm(1.0,U.T,K.T.copy(order='F'),side=1,lower=1,trans_a=1,overwrite_b=1)
    v4=lambda: B.strsm(1.0,L.T,K.T.copy(order='F'),side=1,lower=0,trans_a=0,overwrite_b=1)
    cp=lambda: K.T.copy(order='F')
    tt=lambda: torch.linalg.solve_triangular(torch.from_numpy(U),torch.from_numpy(K).mT,upper=True,left=False)
    print(N, "XL=B: %.3f %.3f  XL^T=B: %.3f %.3f  copy %.3f  torch %.3f"%(t(v1),t(v2),t(v3),t(v4),t(cp),t(tt)))
