import json, sys, math, os, glob
F=0.05
D = sys.argv[1]; variants = sys.argv[2].split(','); forced = sys.argv[3].split(',')
seeds = sorted({os.path.basename(f).split('-')[1][:-5] for f in glob.glob(f'{D}/auto-*.json')})
verbose = len(sys.argv) > 4
tot = {v: [] for v in variants}
for s in seeds:
    try:
        R = {v: json.load(open(f'{D}/{v}-{s}.json')) for v in set(variants) | set(forced)}
    except FileNotFoundError:
        continue
    per = {v: [] for v in variants}
    for case in R['auto']:
        best = min(R[f][case]['rms'] for f in forced)
        row = []
        for v in variants:
            r = (R[v][case]['rms'] + F) / (best + F); per[v].append(math.log(r)); row.append(r)
            if R[v][case]['closed'] != R[v][case]['holes']: row.append('OPEN')
        if verbose and max(row[i] for i in range(len(variants)) if not isinstance(row[i], str)) - min(x for x in row if not isinstance(x, str)) > 0.02:
            print(f"  {case[11:45]:34s}", ' '.join(f'{x:.3f}' if not isinstance(x, str) else x for x in row), ' | ', ' '.join(f"{f} {R[f][case]['rms']:.3g}" for f in forced))
    print(s, ' '.join(f'{v} {math.exp(sum(per[v])/len(per[v])):.4f} (max {math.exp(max(per[v])):.2f})' for v in variants))
    for v in variants: tot[v] += per[v]
print('ALL', ' '.join(f'{v} {math.exp(sum(tot[v])/len(tot[v])):.4f}' for v in variants), len(tot[variants[0]]))
