# usage: follow.sh PATTERN SPEC... : wait until no process matches PATTERN, then queue.sh SPEC...
pat=$1; shift
while pgrep -f "$pat" >/dev/null; do sleep 15; done
exec bash /work/runs41/queue.sh "$@"
