"""What the protocol adapters' tests (grbl, EBB, Marlin, Moonraker) and the
grbl stream bench share: a `motet serve` process with a device on a pty,
its status polled over HTTP while a program drives it, and `motet run` of
the same file as the reference."""

import json
import math
import os
import subprocess
import tempfile
import threading
import time
import urllib.request

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", "..", "..", ".."))
MOTET = os.environ.get("MOTET", os.path.join(ROOT, "target", "debug", "motet"))


class Server:
    """`motet serve MACHINE --grbl pty` (or another device: `--marlin pty`,
    `--ebb pty`) on any free port, stopped on exit."""

    def __init__(self, machine, device="grbl"):
        self.dir = tempfile.mkdtemp(prefix="motet-grbl-")
        self.proc = subprocess.Popen(
            [MOTET, "serve", machine, "--listen", "127.0.0.1:0", "--dir", self.dir, f"--{device}", "pty"],
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
        )
        self.url = None
        self.pty = None
        deadline = time.monotonic() + 30
        while (self.url is None or self.pty is None) and time.monotonic() < deadline:
            line = self.proc.stdout.readline()
            if not line:
                break
            if " at http://" in line:
                self.url = line.split(" at ", 1)[1].strip().rstrip("/")
            if line.startswith(f"{device}: "):
                self.pty = line.split(": ", 1)[1].strip()
        if self.url is None or self.pty is None:
            self.proc.kill()
            raise RuntimeError(f"motet serve printed no address or no {device} pty")
        # The nodes' clocks settle for a few seconds after the start; motion
        # asked for meanwhile waits, which would count as machine time.
        while self.get("/api/status")["connecting"] and time.monotonic() < deadline:
            time.sleep(0.05)

    def get(self, path):
        with urllib.request.urlopen(self.url + path, timeout=5) as r:
            return json.loads(r.read())

    def stream_runs(self):
        """Stream runs started from rest, from the event log."""
        runs = 0
        for e in self.get("/api/events?since=0"):
            text = e.get("message", "")
            if text.startswith("stream run ") and text.endswith(" started from rest"):
                runs = max(runs, int(text.split()[2]))
        return runs

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.proc.terminate()
        try:
            self.proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self.proc.kill()


class Poller:
    """The machine's state, position and speed from /api/status, as often
    as it answers."""

    def __init__(self, server):
        self.server = server
        self.samples = []
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self.run, daemon=True)

    def run(self):
        while not self.stop.is_set():
            s = self.server.get("/api/status")
            self.samples.append((s["state"], s["position"], s["speed"]))
            time.sleep(0.002)

    def __enter__(self):
        self.thread.start()
        return self

    def __exit__(self, *exc):
        self.stop.set()
        self.thread.join()


def reference(machine, gcode_path):
    """`motet run` of the file: its report (final step positions)."""
    out = tempfile.mkdtemp(prefix="motet-grbl-ref-")
    subprocess.run([MOTET, "run", machine, gcode_path, "--out", out, "-q"], check=True)
    with open(os.path.join(out, "report.json")) as f:
        return json.load(f)


def distance_to_polyline(p, pts):
    best = math.inf
    for (ax, ay), (bx, by) in zip(pts, pts[1:]):
        dx, dy = bx - ax, by - ay
        l2 = dx * dx + dy * dy
        t = 0.0 if l2 == 0 else max(0.0, min(1.0, ((p[0] - ax) * dx + (p[1] - ay) * dy) / l2))
        best = min(best, math.hypot(p[0] - ax - t * dx, p[1] - ay - t * dy))
    return best
