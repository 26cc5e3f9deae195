# The ball-and-plate preset with σ_s = 0.01 instead of 0.05, seeds 1 and 2, trials 1-3
# (2026-12-06 05:35-06:18, code of 285eea1 from a snapshot, one torch thread each, the two runs
# side by side on the two cores, then one of them beside a cart-pole run).
for s in 1 2; do
  python -m runners.train +experiment=ball_and_plate_pms seed=$s threads=1 num_trials=3 \
    optimizer.schedule.threshold=0.01 hydra.run.dir=runs/bnp_sigma001_seed_$s &
done; wait
for s in 1 2; do for t in 1 2 3; do
  python -m analysis.evaluate runs/bnp_sigma001_seed_$s --trial $t --runs 10
done; done
# Session 32 (2026-12-06 09:10-, code of 0003f3a from a snapshot, one torch thread each, two
# processes on the two cores): seed 2 resumed one trial at a time to trial 6, and seed 0, trials 1-3,
# then resumed one trial at a time for trials 4 and 5 (resume=runs/bnp_sigma001_seed_0 num_trials=N).
#   for n in 4 5 6; do python -m runners.train resume=runs/bnp_sigma001_seed_2 threads=1 num_trials=$n; done
#   python -m runners.train +experiment=ball_and_plate_pms seed=0 threads=1 num_trials=3 \
#     optimizer.schedule.threshold=0.01 hydra.run.dir=runs/bnp_sigma001_seed_0
#   then analysis.evaluate --trial T --runs 10 for each new trial, as above.
