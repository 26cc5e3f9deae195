cd /work/snap25
echo "$(date +%T) start base_se0 (float64, no reduction, alone)" >> /work/runs25/progress.log
/usr/bin/time -v .venv/bin/python -m runners.train kernel=se seed=0 threads=1 num_trials=5 hydra.run.dir=/work/runs25/base_se0 > /work/runs25/base_se0.out 2>&1
echo "$(date +%T) end base_se0 rc=$?" >> /work/runs25/progress.log
