cd /work/snap40
for r in 1 2; do
 for v in base tuned; do
  if [ $v = tuned ]; then export MALLOC_MMAP_THRESHOLD_=4294967296 MALLOC_TRIM_THRESHOLD_=4294967296 MALLOC_TOP_PAD_=268435456; else unset MALLOC_MMAP_THRESHOLD_ MALLOC_TRIM_THRESHOLD_ MALLOC_TOP_PAD_; fi
  for cfg in "mixed 300" "mixed 60"; do echo -n "$v r$r "; PYTHONPATH=/work/snap40 .venv/bin/python time_step.py (this folder) $cfg 2>&1 | tail -1; done
 done
done
