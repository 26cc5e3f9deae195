# wait for the baseline to end, then the SoD 5-trial run alone, then two learning queues
until grep -q "end base_se0" /work/runs25/progress.log; do sleep 10; done
cd /work/snap25b
echo "$(date +%T) start sod_se0 (float64, reference SoD relative 0.5, alone)" >> /work/runs25/progress.log
/usr/bin/time -v .venv/bin/python -m runners.train kernel=se seed=0 threads=1 num_trials=5 model.reduction_threshold=0.5 model.reduction_mode=relative hydra.run.dir=/work/runs25/sod_se0 > /work/runs25/sod_se0.out 2>&1
echo "$(date +%T) end sod_se0 rc=$?" >> /work/runs25/progress.log
nohup setsid bash /work/runs25/queue.sh sp0:sp:0 se1:se:1 sp2:sp:2 se3:se:3 sp4:sp:4 se5:se:5 sp6:sp:6 se7:se:7 sp8:sp:8 se9:se:9 > /dev/null 2>&1 &
nohup setsid bash /work/runs25/queue.sh sp1:sp:1 se2:se:2 sp3:sp:3 se4:se:4 sp5:sp:5 se6:se:6 sp7:sp:7 se8:se:8 sp9:sp:9 > /dev/null 2>&1 &
