"""Where the float32 mean's error comes from, on the inputs a float64 rollout visits:
(a) the mixed path (float32 cross-covariance, whitened product in float32);
(b) float32 cross-covariance cast up, mean k*·α in float64 (a float64 GEMV);
(c) float64 cross-covariance cast down, whitened product in float32;
(e), (f): as (a), (b) with the inputs centred before the kernel's expansion (SE only).
Errors against the float64 mean, as a fraction of the float64 posterior std; then the
signed (systematic) parts of the mean and std errors."""
import sys
from pathlib import Path
import torch
from common import load, visited_gp_inputs

torch.set_num_threads(1)
run = Path(sys.argv[1]); k = int(sys.argv[2]); pol = int(sys.argv[3])
c = load(run, k, pol)
gp = c.model.gp
X = visited_gp_inputs(c)


def whitened_mean(cache, cross):
    w = torch.linalg.solve_triangular(cache.upper_factor, cross, upper=True, left=False)
    return torch.linalg.vecdot(w, cache.whitened_targets.unsqueeze(-2)).double()


def centred_cross32(kernel, train, inputs):
    """SE cross-covariance in float32 from inputs centred on the training mean (z-space)."""
    il = torch.exp(-kernel.log_lengthscale).detach()[:, None, :]
    z2 = train * il
    centre = z2.mean(-2, keepdim=True)
    z2c, z1c = (z2 - centre).float(), (inputs * il - centre).float()
    log_var = kernel.log_variance.detach().float()[:, None]
    exponent = 2 * z1c @ z2c.mT - z1c.square().sum(-1, keepdim=True) - (z2c.square().sum(-1) - log_var)[:, None, :]
    largest_z1 = float((inputs * il).square().sum(-1).max())
    return exponent.exp(), largest_z1, float(z2.square().sum(-1).max())


with torch.no_grad():
    c64, c32 = gp._prediction_cache(torch.float64), gp._prediction_cache(torch.float32)
    m64, v64 = c64.mean_and_variance(X)
    s64 = v64.sqrt()
    cross64, _ = c64.kernel(X)
    cross32, _ = c32.kernel(X.float())
    alpha = c64.solve[..., -1]  # [G, N]
    print(f"{run.name} model T{k} n={gp.train_inputs.shape[0]}, policy T{pol}; |alpha| max {float(alpha.abs().max()):.2e}, |beta| {float(c32.whitened_targets.norm(dim=-1).max()):.2e}")
    variants = {}
    if hasattr(gp.kernel, "log_lengthscale") and getattr(gp.kernel, "active_dims", None) is None:
        cc32, z1max, z2max = centred_cross32(gp.kernel, gp.train_inputs, X)
        print(f"  |z1|^2 max {z1max:.1f}, |z2|^2 max {z2max:.1f}; cross rel err: uncentred median "
              f"{float(((cross32.double()-cross64).abs()/cross64).median()):.1e}, centred {float(((cc32.double()-cross64).abs()/cross64).median()):.1e}")
        variants["(e) centred f32 cross, f32 whitened product"] = whitened_mean(c32, cc32)
        variants["(f) centred f32 cross, f64 k*.alpha"] = torch.einsum("gmn,gn->gm", cc32.double(), alpha)
    variants["(a) mixed path"] = whitened_mean(c32, cross32)
    variants["(b) f32 cross, f64 k*.alpha"] = torch.einsum("gmn,gn->gm", cross32.double(), alpha)
    variants["(c) f64 cross, f32 whitened product"] = whitened_mean(c32, cross64.float())
    variants["(d) f64 cross, f64 k*.alpha"] = torch.einsum("gmn,gn->gm", cross64, alpha)
    for name, m in variants.items():
        e = (m - m64).abs() / s64
        print("  " + name + ": " + "; ".join(f"out {g} median {float(e[g].median()):.1e} p99 {float(e[g].quantile(0.99)):.1e}" for g in range(e.shape[0])))
    for name in ("(a) mixed path", "(b) f32 cross, f64 k*.alpha"):
        e = (variants[name] - m64) / s64
        print(f"  signed {name}: " + "; ".join(f"out {g} mean {float(e[g].mean()):+.1e} (s.e. {float(e[g].std()/e.shape[1]**0.5):.1e})" for g in range(e.shape[0])))
    _, v32 = c32.mean_and_variance(X.float())
    es = (v32.double().sqrt() - s64) / s64
    print("  signed std error (mixed): " + "; ".join(f"out {g} mean {float(es[g].mean()):+.1e} median {float(es[g].median()):+.1e}" for g in range(es.shape[0])))
