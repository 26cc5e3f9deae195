# one compiled optimisation step (cart-pole SE, M 400, T 60, n_b 200), one thread, median of 15 after 3;
# float64 (the default again) and mixed alternating, two rounds
# (run at 09:08 with a byte-identical copy of ../se_backward/time_step.py in this folder; the copy is gone, the script is the same)
cd /work/main
for round in 1 2; do
  for n in 60 300; do
    for d in float64 mixed; do
      PYTHONPATH=/work/main .venv/bin/python docs/results/mixed_precision/se_backward/time_step.py $d $n 2>/dev/null
    done
  done
done
