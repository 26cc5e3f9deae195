# run_copy.sh SRC DST TRIAL: a copy of run directory SRC in DST holding trials 0..TRIAL-1 only (for along_path.py)
# (run from the repository root; the copy is written to, so it must not be a run to keep)
SRC=$1; DST=$2; K=$3
rm -rf $DST; mkdir -p $DST
tar -C $SRC --exclude=rollouts.mcap --exclude='recording*.rrd' --exclude=.mcpilco.lock --exclude=failed.txt -cf - . | tar -C $DST -xf -
for k in $(seq $K 5); do kk=$(printf %02d $k); rm -rf $DST/checkpoints/trial_$kk $DST/trajectories/trial_$kk.npz $DST/optimization/trial_$kk.csv; done
.venv/bin/python -c "
import pandas as pd; t = pd.read_csv('$DST/summary.csv'); t[t.trial < $K].to_csv('$DST/summary.csv', index=False)"
