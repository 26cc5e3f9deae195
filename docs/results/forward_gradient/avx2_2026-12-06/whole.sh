#!/bin/bash
# One 5-trial SE cart-pole run at thesis settings (the default config), alone on the two
# cores, one torch thread; wall time from /usr/bin/time.
here=$(cd "$(dirname "$0")" && pwd); root=$(cd "$here/../../../.." && pwd)
cd "$root" && date > "$here/whole_time.txt" && /usr/bin/time -v .venv/bin/python -m runners.train kernel=se seed=0 threads=1 num_trials=5 hydra.run.dir=/work/s29/whole_se0 2> /tmp/whole_stderr.txt >/dev/null; date >> "$here/whole_time.txt"
sed -n "/Command being timed/,$ p" /tmp/whole_stderr.txt > "$here/whole_usr_bin_time.txt"; grep -E "Elapsed|User time|Percent|Exit" /tmp/whole_stderr.txt >> "$here/whole_time.txt"
