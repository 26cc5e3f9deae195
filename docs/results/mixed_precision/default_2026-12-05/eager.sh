# float64 (the default again): eager against compiled, one thread, median of 15 after 3, alternating, two rounds
cd /work/main
for round in 1 2; do
  for n in 60 300; do
    for m in eager compiled; do
      PYTHONPATH=/work/main .venv/bin/python docs/results/mixed_precision/default_2026-12-05/time_step_mode.py float64 $n $m 2>/dev/null
    done
  done
done
