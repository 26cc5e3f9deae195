#!/bin/bash
# Alternating processes, one at a time, one torch thread, nothing else on the two cores.
here=$(cd "$(dirname "$0")" && pwd); root=$(cd "$here/../../../.." && pwd)
date; lscpu | grep -E "Model name"; grep -o -m1 'avx512f' /proc/cpuinfo || echo "no avx512f"
for n in 60 300; do
  for round in 1 2; do
    for path in default autograd; do
      extra=""; [ $path = autograd ] && extra=model.gp.forward_gradient=false
      (cd "$root" && .venv/bin/python "$here/step_time.py" $n $path $extra 2>&1 | grep ms/step)
    done
  done
done
date
