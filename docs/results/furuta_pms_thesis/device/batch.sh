#!/bin/bash
# The batch that made this folder's runs on a lent GPU host (2026-12-04, session 18), kept
# for provenance and to run more there. That host has PyTorch, pandas, scipy, matplotlib,
# tqdm, PyYAML and protobuf but no registry: carry wheels of hydra-core, omegaconf,
# antlr4-python3-runtime (built here: `pip wheel --no-deps antlr4-python3-runtime==4.9.3`),
# mcap, mcap-protobuf-support and cma in .whl/ (the device tool's README says how). The
# MuJoCo, PyBullet, Rerun and zstandard wheels do not fit the 64 MiB a call may carry; the
# Furuta needs none of them, so empty stand-ins take their place (imported, never used)
# and the MCAP log is off. Usage there: LIMIT=505 bash <this file>; results in $OUT.
set -u
T0=$(date +%s)
LIMIT=${LIMIT:-480}
python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade \
    --target /tmp/site .whl/*.whl || exit 3
STUBS=/tmp/stubs; mkdir -p $STUBS/rerun
for m in mujoco pybullet pybullet_data; do echo '"""Stand-in: unused by the Furuta."""' > $STUBS/$m.py; done
: > $STUBS/rerun/__init__.py; : > $STUBS/rerun/blueprint.py
echo '__version__ = "0.0.1"  # too old for pandas, which then skips zstd' > $STUBS/zstandard.py
export PYTHONPATH=/tmp/site:$STUBS:$PWD PYTHONUNBUFFERED=1
R=/tmp/r; mkdir -p $R
{ date; nproc; lscpu | grep -E "Model name|Core"; nvidia-smi -L; python3 -c "import torch; print(torch.__version__)"; } > $R/env.txt 2>&1
run() { name=$1; shift; timeout -s INT -k 25 $LIMIT python3 -m runners.train "$@" threads=1 \
    num_trials=6 tracking.mcap=null hydra.run.dir=$R/$name > $R/$name.out 2>&1 & }
for s in 0 1 2; do
    run pms_sp_$s +experiment=furuta_pms kernel=sp seed=$s
    run pms_sep2_$s +experiment=furuta_pms kernel=se_p2 seed=$s
    run df_se_${s}_cuda +experiment=furuta_df seed=$s device=cuda
done
run pms_se_1 +experiment=furuta_pms seed=1
run pms_se_2 +experiment=furuta_pms seed=2
( while sleep 30; do echo "$(( $(date +%s) - T0 )) s $(cat /proc/loadavg)"; done ) > $R/load.txt 2>&1 &
LOAD=$!
wait $(jobs -p | grep -v "^$LOAD$") 2>/dev/null
kill $LOAD
tar czf $OUT/runs.tgz --exclude='*.rrd' -C /tmp r
