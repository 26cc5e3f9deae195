import torch, time
torch.set_num_threads(1)
for dt in [torch.float32, torch.float64]:
    a = torch.randn(2, 300, 300, dtype=dt); b = torch.randn(2, 300, 400, dtype=dt)
    for _ in range(3): torch.bmm(a, b)
    ts=[]
    for _ in range(20):
        t0=time.perf_counter(); torch.bmm(a, b); ts.append(time.perf_counter()-t0)
    ts.sort(); t=ts[10]; print(dt, f"{t*1e3:.3f} ms, {2*2*300*300*400/t/1e9:.1f} GFLOP/s")
