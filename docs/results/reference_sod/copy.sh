# copy finished SoD run directories into the docs page (no MCAP, no locks)
for d in /work/runs25/s[ep][0-9]; do
  n=$(basename $d); k=${n:0:2}; s=${n:2}
  if pgrep -f "resume=$d " >/dev/null || pgrep -f "hydra.run.dir=$d " >/dev/null; then echo "running: $n"; continue; fi
  dst=/work/main/docs/results/reference_sod/sod_${k}_seed_${s}; rm -rf $dst; mkdir -p $dst
  tar -C $d --exclude=rollouts.mcap --exclude='recording*.rrd' --exclude=.mcpilco.lock --exclude=.hydra --exclude=failed.txt -cf - . | tar -C $dst -xf -
done
