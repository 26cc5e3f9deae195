# usage: queue.sh NAME:KERNEL:SEED ... ; float64 default settings with optimizer.schedule.window=100 (n_s).
# Ran from a snapshot of the code (/work/snap30, commit 1dd3285) into /work/runs30 (machine-local
# paths; the run directories were copied here without their MCAP logs). Resumes NAME's dir if it has trials; one trial at a time until success or trial 5.
cd /work/snap30
for spec in "$@"; do
  IFS=: read NAME K S <<< "$spec"; D=/work/runs30/$NAME
  echo "$(date +%T) start $NAME" >> /work/runs30/progress.log
  for n in 1 2 3 4 5; do
    if [ -f $D/summary.csv ]; then
      done_n=$(tail -1 $D/summary.csv | cut -d, -f1); last=$(tail -1 $D/summary.csv | cut -d, -f3)
      [ "$last" = "True" ] && break
      [ $done_n -ge $n ] && continue
      .venv/bin/python -m runners.train resume=$D threads=1 num_trials=$n >> $D.out 2>&1
    else
      .venv/bin/python -m runners.train kernel=$K seed=$S threads=1 num_trials=1 optimizer.schedule.window=100 hydra.run.dir=$D >> $D.out 2>&1
    fi
    last=$(tail -1 $D/summary.csv | cut -d, -f3)
    echo "$(date +%T) $NAME trial $n success=$last" >> /work/runs30/progress.log
    [ "$last" = "True" ] && break
  done
done
