#!/bin/bash
# trial 3 of the seed-0 whole run, resumed from its trial-2 checkpoint with the code before
# (852b312) and after (806aeaf): where do the two searches part?
for v in new old; do
  root=/work/snap26; [ $v = old ] && root=/work/s26/old
  DST=/work/s26/pw_$v; rm -rf $DST; mkdir -p $DST
  tar -C /work/s26/whole_se0 --exclude=rollouts.mcap --exclude='recording*.rrd' --exclude=.mcpilco.lock --exclude=failed.txt -cf - . | tar -C $DST -xf -
  for k in 3 4 5; do kk=$(printf %02d $k); rm -rf $DST/checkpoints/trial_$kk $DST/trajectories/trial_$kk.npz $DST/optimization/trial_$kk.csv; done
  /work/main/.venv/bin/python -c "
import pandas as pd; t = pd.read_csv('$DST/summary.csv'); t[t.trial < 3].to_csv('$DST/summary.csv', index=False)"
  (cd $root && .venv/bin/python -m runners.train resume=$DST threads=1 num_trials=3 > $DST.out 2>&1)
  echo "$(date +%T) $v done rc $?" >> /work/s26/pathwise.log
done
