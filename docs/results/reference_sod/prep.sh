# usage: prep.sh NAME KERNEL SEED D — the float64 run (no reduction) of that seed cut back to
# trial D-1 (the SoD run is that run until trial D, the first where the SoD drops a sample),
# its config switched to the reference SoD; queue.sh then resumes it one trial at a time.
NAME=$1; K=$2; S=$3; D=$4; SRC=/work/runs41/f64_${K}_seed_${S}; DST=/work/runs25/$NAME
rm -rf $DST; mkdir -p $DST
tar -C $SRC --exclude=rollouts.mcap --exclude='recording*.rrd' --exclude=.mcpilco.lock --exclude=failed.txt -cf - . | tar -C $DST -xf -
for k in $(seq $D 5); do kk=$(printf %02d $k); rm -rf $DST/checkpoints/trial_$kk $DST/trajectories/trial_$kk.npz $DST/optimization/trial_$kk.csv; done
/work/main/.venv/bin/python - $DST $D <<'PY'
import sys, pandas as pd
from omegaconf import OmegaConf
dst, d = sys.argv[1], int(sys.argv[2])
table = pd.read_csv(f"{dst}/summary.csv"); table[table.trial < d].to_csv(f"{dst}/summary.csv", index=False)
cfg = OmegaConf.load(f"{dst}/config.yaml"); cfg.model.reduction_threshold = 0.5; cfg.model.reduction_mode = "relative"
OmegaConf.save(cfg, f"{dst}/config.yaml")
PY
echo "$(date +%T) prepared $NAME from $SRC cut back to trial $((D-1))" >> /work/runs25/progress.log
