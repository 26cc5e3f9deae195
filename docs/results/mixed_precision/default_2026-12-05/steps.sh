# one compiled optimisation step (cart-pole SE, M 400, T 60, n_b 200), one thread, median of 15 after 3;
# float64 (the default again) and mixed alternating, two rounds
cd /work/main
for round in 1 2; do
  for n in 60 300; do
    for d in float64 mixed; do
      PYTHONPATH=/work/main .venv/bin/python docs/results/mixed_precision/default_2026-12-05/time_step.py $d $n 2>/dev/null
    done
  done
done
