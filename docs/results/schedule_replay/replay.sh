# Replays of stored traces through changed monitoring schedules (analysis.schedule_replay);
# run from the repository root: bash docs/results/schedule_replay/replay.sh
out=docs/results/schedule_replay
cartpole=docs/results/mixed_precision/recheck_2026-12-05   # f64_* and mixed runs, thesis settings
bnp="docs/results/ball_and_plate/paper_seed_0 docs/results/ball_and_plate/paper_seed_1 docs/results/ball_and_plate/paper_seed_2"
python -m analysis.schedule_replay $cartpole --set window=100 --csv $out/cartpole_window_100.csv > $out/cartpole_window_100.txt
python -m analysis.schedule_replay $cartpole --set bias_correction=true --csv $out/cartpole_bias_correction.csv > $out/cartpole_bias_correction.txt
python -m analysis.schedule_replay $bnp --set bias_correction=true --csv $out/bnp_bias_correction.csv > $out/bnp_bias_correction.txt
python -m analysis.schedule_replay $bnp --set threshold=0.01 --csv $out/bnp_threshold_0.01.csv > $out/bnp_threshold_0.01.txt
python -m analysis.schedule_replay $bnp --set threshold=0.01 --set bias_correction=true --csv $out/bnp_threshold_0.01_bias_correction.csv > $out/bnp_threshold_0.01_bias_correction.txt
python -m analysis.schedule_replay $cartpole --set window=100 --set bias_correction=true --csv $out/cartpole_window_100_bias_correction.csv > $out/cartpole_window_100_bias_correction.txt
python docs/results/schedule_replay/summary.py > $out/summary.txt
