# per-trial: n, kept, steps, ms/step, fit s, eval cost, success
f=$1/summary.csv
python3 - "$f" <<'PY'
import csv,sys
rows=list(csv.DictReader(open(sys.argv[1])))
for r in rows[1:]:
    s=int(float(r['optimization_steps'])); t=float(r['optimization_seconds'])
    print(r['trial'], 'n', r['gp_samples'], 'kept', r['gp_kept'], 'steps', s, 'ms/step %.0f'%(1000*t/s), 'opt s %.0f'%t, 'fit s %.1f'%float(r['fit_seconds']), 'eval %.1f'%float(r['eval_cost']), r['success'])
print('total opt s %.0f, fit s %.1f'%(sum(float(r['optimization_seconds']) for r in rows[1:]), sum(float(r['fit_seconds']) for r in rows[1:])))
PY
