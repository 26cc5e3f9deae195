#!/bin/bash
# Step time, compiled float64, one thread: code before (OLD, a checkout of 852b312) against
# after (NEW), alternating processes, nothing else running. Usage: ab.sh OLD NEW > ab.txt
old=$1; new=$2; here=$(cd "$(dirname "$0")" && pwd)
for setting in se sp; do
  for n in 60 300; do
    rounds=3; [ $setting = sp ] && rounds=1
    for round in $(seq $rounds); do
      for v in old new; do
        root=$old; [ $v = new ] && root=$new
        (cd "$root" && PYTHONPATH="$root" .venv/bin/python "$here/steps.py" $n $v $setting 2>&1 | grep ms/step)
      done
    done
  done
done
date
