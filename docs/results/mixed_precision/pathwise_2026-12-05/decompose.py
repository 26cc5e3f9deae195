"""Per-step GP prediction error of the float32 path on the inputs a float64 rollout visits:
mean error and std error relative to the float64 std (what moves the particles)."""
import sys
from pathlib import Path
import torch
from common import load, visited_gp_inputs

torch.set_num_threads(1)
run = Path(sys.argv[1]); k = int(sys.argv[2]); pol = int(sys.argv[3])
c = load(run, k, pol)
gp = c.model.gp
X = visited_gp_inputs(c)
print("inputs", tuple(X.shape), "n", gp.train_inputs.shape)
with torch.no_grad():
    m64, v64 = gp.predict(X)
    m32, v32 = gp.predict(X.float())
s64 = v64.clamp_min(0).sqrt(); s32 = v32.double().sqrt()
dm = (m32.double() - m64).abs(); ds = (s32 - s64).abs()
for g in range(m64.shape[0]):
    print(f"output {g}: std64 median {float(s64[g].median()):.2e} min {float(s64[g].min()):.2e}; "
          f"|mean err| median {float(dm[g].median()):.2e} p99 {float(dm[g].quantile(0.99)):.2e}; "
          f"|std err| median {float(ds[g].median()):.2e} p99 {float(ds[g].quantile(0.99)):.2e}; "
          f"mean err / std64 median {float((dm[g]/s64[g]).median()):.2e} p99 {float((dm[g]/s64[g]).quantile(0.99)):.2e}; "
          f"rel std err median {float((ds[g]/s64[g]).median()):.2e} p99 {float((ds[g]/s64[g]).quantile(0.99)):.2e}; "
          f"v64/k** median {float((v64[g]/gp.kernel.variance.flatten()[g] if hasattr(gp.kernel,'variance') else v64[g]).median()):.2e}")
