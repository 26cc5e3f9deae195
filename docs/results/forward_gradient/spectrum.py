"""Eigenvalues of a saved GP's K above t·σ_n², per output: python spectrum.py RUN_DIR TRIAL."""
import sys, torch
from omegaconf import OmegaConf
from mcpilco.build import build
torch.set_num_threads(1)
run, trial = sys.argv[1], sys.argv[2]
cfg = OmegaConf.load(f"{run}/config.yaml")
model = build(cfg).components.model
model.load_gp(torch.load(f"{run}/checkpoints/{trial}/model.pt", weights_only=True))
gp = model.gp
X = gp.train_inputs
with torch.no_grad():
    K = gp.kernel(X, X)
    noise = gp.noise_variance
    for g in range(K.shape[0]):
        ev = torch.linalg.eigvalsh(K[g]).flip(0)
        s2 = float(noise[g])
        counts = {t: int((ev > t * s2).sum()) for t in (1e-2, 1e-4, 1e-6, 1e-8, 1e-10)}
        print(f"{trial} out{g} n={X.shape[0]} σ²={s2:.3g} k**={float(K[g,0,0]):.3g} λmax={float(ev[0]):.3g} rank(λ>tσ²): {counts}")
