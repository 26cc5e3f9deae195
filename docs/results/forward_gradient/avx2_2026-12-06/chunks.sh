#!/bin/bash
# K = 1, 6, 12 time steps per compiled call (compile_steps), alternating processes, one torch
# thread, nothing else running (2026-12-06 01:40-01:51, AVX2 host).
here=$(cd "$(dirname "$0")" && pwd); root=$(cd "$here/../../../.." && pwd)
date; grep -o -m1 'avx512f' /proc/cpuinfo || echo "no avx512f"
for n in 60 300; do
  for round in 1 2; do
    for k in 1 6 12; do
      (cd "$root" && .venv/bin/python "$here/step_time.py" $n K=$k --keep-freed-memory compile_steps=$k 2>&1 | grep ms/step)
    done
  done
done
date
