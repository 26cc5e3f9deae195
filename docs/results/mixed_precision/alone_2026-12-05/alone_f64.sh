cd /work/main
echo "start $(date +%T)" >> /work/runs42/alone_f64.log
.venv/bin/python -c "from runners.bench import matmul_gflops; import torch; torch.set_num_threads(1); print('float64 GEMM', round(matmul_gflops(),1), 'GFLOP/s')" >> /work/runs42/alone_f64.log 2>&1
/usr/bin/time -v .venv/bin/python -m runners.train kernel=se seed=0 threads=1 num_trials=5 rollout_dtype=null hydra.run.dir=/work/runs42/f64_se_seed_0_alone > /work/runs42/f64_se_seed_0_alone.out 2> /work/runs42/f64_se_seed_0_alone.err
echo "end $(date +%T) rc $?" >> /work/runs42/alone_f64.log
