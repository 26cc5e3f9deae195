# usage: queue2.sh WAITNAME NAME:KERNEL:SEED ... — wait for WAITNAME's running trial to end, then queue.sh
while pgrep -f "resume=/work/runs25/$1 " > /dev/null; do sleep 10; done
shift
exec bash /work/runs25/queue.sh "$@"
