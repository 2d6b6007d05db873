"""Headless Chromium driven over the DevTools protocol, for the tests that
open a page as a person would (tests/test_webview.py).

Chromium reads the protocol's commands from file descriptor 3 and writes
its replies to 4 (``--remote-debugging-pipe``), one JSON message each,
ended by a NUL byte. A test opens a page, waits for it to load, runs a
script (a promise's value comes back) and reads the console's messages
and uncaught exceptions. No virtual time: the page's rendering steps run
as in a browser on a screen (IntersectionObserver, requestAnimationFrame).
"""

import json
import os
import select
import shutil
import subprocess


def find_chromium():
    """The path of a Chromium binary, or None."""
    for name in ("chromium", "chromium-browser", "google-chrome"):
        p = shutil.which(name)
        if p:
            return p
    return None


#: WebGL without a GPU (ANGLE on SwiftShader); a headless window counts as hidden, where
#: Chromium would throttle the page's timers and frames
FLAGS = ["--headless", "--no-sandbox", "--use-angle=swiftshader", "--enable-unsafe-swiftshader",
         "--disable-renderer-backgrounding", "--disable-backgrounding-occluded-windows",
         "--disable-background-timer-throttling", "--allow-file-access-from-files"]


class Chromium:
    """A headless Chromium with one page, driven over the protocol's pipe.

    Parameters
    ----------
    browser : str
        The binary (:func:`find_chromium`).
    flags : sequence of str
        More command-line flags (after :data:`FLAGS`).
    timeout : float
        Seconds a script may run.
    size : (int, int)
        The window's size.
    """

    def __init__(self, browser, flags=(), *, timeout=120, size=(1000, 800)):
        to_r, to_w = os.pipe()
        from_r, from_w = os.pipe()

        def fds():   # the pipe's ends at 3 (commands in) and 4 (replies out), as Chromium expects
            a, b = os.dup(to_r), os.dup(from_w)     # out of the way of 3 and 4 first
            os.dup2(a, 3)
            os.dup2(b, 4)
            os.set_inheritable(3, True)
            os.set_inheritable(4, True)

        self.proc = subprocess.Popen([browser, *FLAGS, *flags, f"--window-size={size[0]},{size[1]}",
                                      "--remote-debugging-pipe", "about:blank"],
                                     close_fds=False, preexec_fn=fds,
                                     stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        os.close(to_r)
        os.close(from_w)
        self.w, self.r = os.fdopen(to_w, "wb"), os.fdopen(from_r, "rb")
        self.timeout, self.n, self.events, self.buf = timeout, 0, [], b""
        page = [t for t in self.call("Target.getTargets")["targetInfos"] if t["type"] == "page"][0]
        self.session = self.call("Target.attachToTarget", targetId=page["targetId"], flatten=True)["sessionId"]
        self.call("Runtime.enable", session=True)
        self.call("Page.enable", session=True)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def open(self, url):
        """Go to ``url`` and wait for its load event."""
        self.call("Page.navigate", session=True, url=url)
        self.evaluate("new Promise(function (ok) { (function wait() { if (document.readyState === 'complete') ok(1);"
                      " else setTimeout(wait, 10); })(); })")

    def _read(self):
        while b"\0" not in self.buf:
            if not select.select([self.r], [], [], self.timeout + 30)[0]:
                raise TimeoutError(f"chromium did not answer in {self.timeout + 30} s")
            chunk = os.read(self.r.fileno(), 1 << 20)
            if not chunk:
                raise RuntimeError("chromium closed the pipe")
            self.buf += chunk
        msg, self.buf = self.buf.split(b"\0", 1)
        return json.loads(msg)

    def call(self, method, session=False, **params):
        """Send a command (to the page with ``session``) and return its result."""
        self.n += 1
        msg = {"id": self.n, "method": method, "params": params}
        if session:
            msg["sessionId"] = self.session
        self.w.write(json.dumps(msg).encode() + b"\0")
        self.w.flush()
        while True:
            m = self._read()
            if m.get("id") == self.n:
                if "error" in m:
                    raise RuntimeError(m["error"])
                return m["result"]
            self.events.append(m)

    def evaluate(self, expression):
        """The value of a script in the page (a promise's, once it settles)."""
        r = self.call("Runtime.evaluate", session=True, expression=expression, awaitPromise=True,
                      returnByValue=True, timeout=self.timeout * 1000)
        if "exceptionDetails" in r:
            raise RuntimeError(r["exceptionDetails"])
        return r["result"].get("value")

    def console(self):
        """The console's messages and the uncaught exceptions so far: (type, text) pairs."""
        out = []
        for e in self.events:
            if e.get("method") == "Runtime.consoleAPICalled":
                out.append((e["params"]["type"], " ".join(str(a.get("value", a.get("description"))) for a in e["params"]["args"])))
            elif e.get("method") == "Runtime.exceptionThrown":
                out.append(("exception", json.dumps(e["params"]["exceptionDetails"])[:500]))
        return out

    def close(self):
        self.w.close()
        self.r.close()
        self.proc.kill()
        self.proc.wait()


