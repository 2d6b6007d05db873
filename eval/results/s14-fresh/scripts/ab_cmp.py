import json, sys, math
b=[json.load(open(f'ab-7dc63bd-run{r}.json')) for r in (1,2)]
m=[json.load(open(f'ab-024d3b5-run{r}.json')) for r in (1,2)]
names=list(b[0])
diff=[n for n in names if b[0][n][0]!=m[0][n][0]]
print('cases', len(names), 'outputs different', len(diff), diff)
print('base run-to-run different', sum(b[0][n][0]!=b[1][n][0] for n in names), 'main', sum(m[0][n][0]!=m[1][n][0] for n in names))
def best(runs,n): return min(r[n][1] for r in runs)
tb=sum(best(b,n) for n in names); tm=sum(best(m,n) for n in names)
print(f'total best-of-2 seconds: base {tb:.2f} main {tm:.2f} ratio {tm/tb:.3f}')
for group in ('s1434622212','s2631639849','b745285506','b1614967854'):
    ns=[n for n in names if n.startswith(group)]
    gb=sum(best(b,n) for n in ns); gm=sum(best(m,n) for n in ns)
    print(f'  {group}: {len(ns)} cases base {gb:.2f} s main {gm:.2f} s')
rows=sorted(names, key=lambda n: best(m,n)/best(b,n))
print('largest changes (main/base, best of 2):')
for n in rows[:8]+rows[-4:]:
    print(f'  {n:42s} base {best(b,n):6.2f} main {best(m,n):6.2f} x{best(m,n)/best(b,n):.2f}  holes_after {b[0][n][2]}->{m[0][n][2]} boundary {b[0][n][3]}->{m[0][n][3]}')
