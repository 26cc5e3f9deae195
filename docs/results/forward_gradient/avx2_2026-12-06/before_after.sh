#!/bin/bash
# The default step of the code before issue 26 (BEFORE, a checkout of 5f5ea0e) against
# today's (AFTER), alternating processes, one torch thread, nothing else running.
# Usage: before_after.sh BEFORE AFTER > before_after.txt
before=$1; after=$2; here=$(cd "$(dirname "$0")" && pwd)
date; grep -o -m1 'avx512f' /proc/cpuinfo || echo "no avx512f"
for n in 60 300; do
  for round in 1 2; do
    for v in before after; do
      root=$before; [ $v = after ] && root=$after
      (cd "$root" && PYTHONPATH="$root" .venv/bin/python "$here/step_time.py" $n $v 2>&1 | grep ms/step)
    done
  done
done
date
