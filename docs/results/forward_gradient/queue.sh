# usage: queue.sh KERNEL:SEED ... ; float64 default, code of snap26 (806aeaf); one trial at a time until success or trial 5.
cd /work/snap26
for spec in "$@"; do
  IFS=: read K S <<< "$spec"; D=/work/s26/learn/${K}_seed_$S
  echo "$(date +%T) start ${K}_$S" >> /work/s26/learn/progress.log
  for n in 1 2 3 4 5; do
    if [ -f $D/summary.csv ]; then
      done_n=$(tail -1 $D/summary.csv | cut -d, -f1); last=$(tail -1 $D/summary.csv | cut -d, -f3)
      [ "$last" = "True" ] && break
      [ $done_n -ge $n ] && continue
      .venv/bin/python -m runners.train resume=$D threads=1 num_trials=$n >> $D.out 2>&1
    else
      .venv/bin/python -m runners.train kernel=$K seed=$S threads=1 num_trials=1 hydra.run.dir=$D >> $D.out 2>&1
    fi
    last=$(tail -1 $D/summary.csv | cut -d, -f3)
    echo "$(date +%T) ${K}_$S trial $n success=$last" >> /work/s26/learn/progress.log
    [ "$last" = "True" ] && break
  done
done
