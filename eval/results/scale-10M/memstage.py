"""Peak RSS by stage of a command-line repair: python memstage.py SCAN -o OUT --report R [options] (from a tree root)."""
import sys, time, threading; sys.path.insert(0,'.')
import shellrepair.cli as cli
stage = ['start']; peaks = {}
def rss():
    for l in open('/proc/self/status'):
        if l.startswith('VmRSS'): return int(l.split()[1]) // 1024
def sampler():
    while True:
        r = rss(); s = stage[0]; peaks[s] = max(peaks.get(s, 0), r); time.sleep(0.02)
threading.Thread(target=sampler, daemon=True).start()
def wrap(mod, name, label):
    f = getattr(mod, name)
    def g(*a, **k):
        prev = stage[0]; stage[0] = label
        try: return f(*a, **k)
        finally: stage[0] = 'after ' + label
    setattr(mod, name, g)
import shellrepair.repair as rp
import shellrepair.mesh.io as io
wrap(io, 'read_mesh', 'read'); wrap(rp, 'repair_mesh', 'repair'); wrap(cli, '_scan_up', 'up'); wrap(io, 'mesh_bytes', 'bytes')
import shellrepair.repair
sys.argv = ['shellrepair', 'repair'] + sys.argv[1:]
try:
    cli.main()
except SystemExit:
    pass
time.sleep(0.1)
print(peaks)
