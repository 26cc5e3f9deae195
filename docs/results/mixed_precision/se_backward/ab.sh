for r in 1 2 3; do for v in A B; do for cfg in "mixed 60" "mixed 300" "mixed 300 sp" "float64 300"; do
 echo -n "$v r$r "; (cd /work/ab$v && PYTHONPATH=/work/ab$v .venv/bin/python /tmp/t1.py $cfg 2>&1 | tail -1); done; done; done
