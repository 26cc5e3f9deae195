# copy SoD run directories into the docs page (no MCAP, no locks): those a queue has worked
# on and that are not running now, and the five that equal the float64 run (nothing to run)
IDENTICAL="se1 se2 sp2 sp3 sp5"
for d in /work/runs25/s[ep][0-9]; do
  n=$(basename $d); k=${n:0:2}; s=${n:2}
  if pgrep -f "resume=$d " >/dev/null || pgrep -f "hydra.run.dir=$d " >/dev/null; then echo "running: $n"; continue; fi
  if ! grep -q "start $n\$" /work/runs25/progress.log && [[ " $IDENTICAL " != *" $n "* ]]; then echo "not started: $n"; continue; fi
  dst=/work/main/docs/results/reference_sod/sod_${k}_seed_${s}; rm -rf $dst; mkdir -p $dst
  tar -C $d --exclude=rollouts.mcap --exclude='recording*.rrd' --exclude=.mcpilco.lock --exclude=.hydra --exclude=failed.txt -cf - . | tar -C $dst -xf -
done
