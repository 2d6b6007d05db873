"""The timeline the other scripts here print: calls wrapped in place, each
logged with its thread and its start and end in ms from start()."""
import threading
import time


class Timeline:
    def __init__(self):
        self.t0 = 0.0
        self.log = []

    def start(self):
        self.log.clear()
        self.t0 = time.perf_counter()

    def record(self, label, t):
        """Log ``label`` as begun at perf_counter ``t`` and ended now."""
        self.log.append((threading.current_thread().name[:10], label, (t - self.t0) * 1e3,
                         (time.perf_counter() - self.t0) * 1e3))

    def wrap(self, mod, name, label=None):
        """Replace ``mod.name`` by a call of it that is logged."""
        f = getattr(mod, name)

        def g(*a, **k):
            t = time.perf_counter()
            try:
                return f(*a, **k)
            finally:
                self.record(label or name, t)

        setattr(mod, name, g)

    def print(self, log=None, longer=1.0, before=None):
        """The calls longer than ``longer`` ms (begun before ``before`` ms), by start."""
        for th, n, a, b in sorted(self.log if log is None else log, key=lambda x: x[2]):
            if b - a > longer and (before is None or a < before):
                print(f"{th:10s} {n:34s} {a:7.1f} -> {b:7.1f}  ({b-a:6.1f})")
