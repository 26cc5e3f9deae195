# usage: queue.sh NAME:KERNEL:SEED ... ; float64 default settings with optimizer.schedule.window=100 (n_s),
# one trial at a time until success or trial 5 (../until_success.sh). Ran from a snapshot of the
# code (/work/snap30, commit 1dd3285) into /work/runs30 (machine-local paths; the run directories
# were copied here without their MCAP logs).
exec bash "$(dirname "$0")/../until_success.sh" /work/snap30 /work/runs30 "optimizer.schedule.window=100" "$@"
