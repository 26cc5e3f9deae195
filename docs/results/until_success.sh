# usage: until_success.sh CODE_DIR RUNS_DIR "OVERRIDES" NAME:KERNEL:SEED ...
# The cart-pole "trials to solve" protocol: each run one trial at a time (runners.train, one
# torch thread) until its first success or trial 5; a run directory with trials is resumed.
# OVERRIDES go to each run's first call (a resumed run keeps its saved config); progress is
# appended to RUNS_DIR/progress.log, each run's output to RUNS_DIR/NAME.out.
code=$1 runs=$2 overrides=$3; shift 3
cd "$code"
for spec in "$@"; do
  IFS=: read NAME K S <<< "$spec"; D=$runs/$NAME
  echo "$(date +%T) start $NAME" >> "$runs/progress.log"
  for n in 1 2 3 4 5; do
    if [ -f $D/summary.csv ]; then
      done_n=$(tail -1 $D/summary.csv | cut -d, -f1); last=$(tail -1 $D/summary.csv | cut -d, -f3)
      [ "$last" = "True" ] && break
      [ $done_n -ge $n ] && continue
      .venv/bin/python -m runners.train resume=$D threads=1 num_trials=$n >> $D.out 2>&1
    else
      .venv/bin/python -m runners.train kernel=$K seed=$S threads=1 num_trials=1 $overrides hydra.run.dir=$D >> $D.out 2>&1
    fi
    last=$(tail -1 $D/summary.csv | cut -d, -f3)
    echo "$(date +%T) $NAME trial $n success=$last" >> "$runs/progress.log"
    [ "$last" = "True" ] && break
  done
done
