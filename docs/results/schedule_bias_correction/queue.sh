# usage: queue.sh NAME:KERNEL:SEED ... ; float64 default settings with n_s = 100 and the
# monitoring signal's bias correction (optimizer.schedule.window=100
# optimizer.schedule.bias_correction=true), one trial at a time until success or trial 5
# (../until_success.sh). Ran from a snapshot of the code (/work/snap31b, commit 6dd6d0d) into
# /work/runs31/bc (machine-local paths; the run directories were copied here without their
# MCAP logs).
exec bash "$(dirname "$0")/../until_success.sh" /work/snap31b /work/runs31/bc \
  "optimizer.schedule.window=100 optimizer.schedule.bias_correction=true" "$@"
