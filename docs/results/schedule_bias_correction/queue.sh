# usage: queue.sh NAME:KERNEL:SEED ... ; float64 default settings with n_s = 100 and the
# monitoring signal's bias correction (optimizer.schedule.window=100
# optimizer.schedule.bias_correction=true), one trial at a time until success or trial 5
# (../until_success.sh). Ran from a snapshot of the code (/work/snap31b, commit 6dd6d0d) into
# /work/runs31/bc (machine-local paths; the run directories were copied here without their
# MCAP logs). SE seeds 5-7 (session 32) ran from /work/snap32 (commit e1db200, the same
# training code): until_success.sh /work/snap32 /work/runs31/bc "<the overrides below>"
# bc_se_seed_5:se:5 bc_se_seed_7:se:7, and bc_se_seed_6:se:6 beside it.
exec bash "$(dirname "$0")/../until_success.sh" /work/snap31b /work/runs31/bc \
  "optimizer.schedule.window=100 optimizer.schedule.bias_correction=true" "$@"
