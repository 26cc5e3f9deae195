# usage: queue.sh NAME:KERNEL:SEED ... ; float64 + reference SoD (relative 0.5); one trial at a time until success or trial 5.
cd /work/snap25b
SOD="model.reduction_threshold=0.5 model.reduction_mode=relative"
for spec in "$@"; do
  IFS=: read NAME K S <<< "$spec"; D=/work/runs25/$NAME
  echo "$(date +%T) start $NAME" >> /work/runs25/progress.log
  for n in 1 2 3 4 5; do
    if [ -f $D/summary.csv ]; then
      done_n=$(tail -1 $D/summary.csv | cut -d, -f1); last=$(tail -1 $D/summary.csv | cut -d, -f3)
      [ "$last" = "True" ] && break
      [ $done_n -ge $n ] && continue
      .venv/bin/python -m runners.train resume=$D threads=1 num_trials=$n >> $D.out 2>&1
    else
      .venv/bin/python -m runners.train kernel=$K seed=$S threads=1 num_trials=1 $SOD hydra.run.dir=$D >> $D.out 2>&1
    fi
    last=$(tail -1 $D/summary.csv | cut -d, -f3)
    echo "$(date +%T) $NAME trial $n success=$last" >> /work/runs25/progress.log
    [ "$last" = "True" ] && break
  done
done
