"""autoonly with an order-3 weight: python autow.py W BASE.json SEED OUT.json"""
import sys, runpy
sys.path.insert(0, '.')
w = float(sys.argv[1])
import shellrepair.fill.selftest as S
orig = S.best_candidate
def weighted(errors):
    e = dict(errors)
    if 3 in e and 2 in e:
        e[3] = e[3] * w
    return orig(e)
S.best_candidate = weighted
sys.argv = ['autoonly.py'] + sys.argv[2:]
runpy.run_path('eval/results/order-test/auto-rerun-14913b1/autoonly.py', run_name='__main__')
