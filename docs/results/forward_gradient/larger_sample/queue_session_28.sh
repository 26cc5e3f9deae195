# usage: queue2.sh FG KERNEL:SEED ... ; FG = true|false (model.gp.forward_gradient); code of
# snap26b (ce94f35); one trial at a time until success or trial 5 (resumable: rerun the same line).
cd /work/snap26b
FG=$1; shift
for spec in "$@"; do
  IFS=: read K S <<< "$spec"; NAME=fg_${FG}_${K}_seed_$S; D=/work/s28/learn2/$NAME
  echo "$(date +%T) start $NAME" >> /work/s28/learn2/progress.log
  for n in 1 2 3 4 5; do
    if [ -f $D/summary.csv ]; then
      done_n=$(tail -1 $D/summary.csv | cut -d, -f1); last=$(tail -1 $D/summary.csv | cut -d, -f3)
      [ "$last" = "True" ] && break
      [ $done_n -ge $n ] && continue
      .venv/bin/python -m runners.train resume=$D threads=1 num_trials=$n >> $D.out 2>&1
    else
      .venv/bin/python -m runners.train kernel=$K seed=$S threads=1 num_trials=1 model.gp.forward_gradient=$FG hydra.run.dir=$D >> $D.out 2>&1
    fi
    last=$(tail -1 $D/summary.csv | cut -d, -f3)
    echo "$(date +%T) $NAME trial $n success=$last" >> /work/s28/learn2/progress.log
    [ "$last" = "True" ] && break
  done
done
