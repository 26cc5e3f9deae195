for v in D N; do
  if [ $v = D ]; then T=/work/abD; else T=/work/snap30b; fi
  rm -rf /tmp/logab_$v
  S=$(date +%s.%N)
  (cd $T && PYTHONPATH=$T .venv/bin/python -m runners.train +experiment=furuta_pms kernel=sp seed=2 threads=1 num_trials=1 optimizer.max_steps_first_trial=300 tracking.mcap=null hydra.run.dir=/tmp/logab_$v > /tmp/logab_$v.out 2>&1)
  E=$(date +%s.%N)
  echo "$v wall $(echo "$E - $S" | bc) s; $(cut -d, -f1,2,16,17 /tmp/logab_$v/summary.csv | tail -1); trace lines $(grep -c torch.__trace /tmp/logab_$v/train.log)"
done
