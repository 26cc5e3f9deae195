#!/bin/bash
# Compiled against eager default step (float64, forward gradient), alternating processes,
# one at a time, one torch thread; the training runs of this session are stopped
# (SIGSTOP) meanwhile, so nothing else runs on the two cores.
here=$(cd "$(dirname "$0")" && pwd); root=$(cd "$here/../../../.." && pwd)
timer="$here/../avx2_2026-12-06/step_time.py"
pids=$(pgrep -f "runners.train" | tr '\n' ' ')
trap 'kill -CONT $pids 2>/dev/null' EXIT
kill -STOP $pids; echo "stopped: $pids"
date; lscpu | grep -E "Model name"; grep -o -m1 'avx512f' /proc/cpuinfo || echo "no avx512f"
for n in 300 60; do
  for round in 1 2; do
    for mode in compiled eager; do
      flag=""; [ $mode = eager ] && flag=--eager
      (cd "$root" && .venv/bin/python "$timer" $n $mode $flag --keep-freed-memory 2>&1 | grep ms/step)
    done
  done
done
date
