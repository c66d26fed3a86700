"""A grbl sender streaming 20,000 short arcs to `motet serve --grbl pty`.

Generates a file of 20,000 `G3` arcs of 2° on a 20 mm circle (0.7 mm each),
streams it with pygrbl-streamer (character counting against the 128-byte
receive buffer), and prints:

- how many times the machine stopped at rest between moves (stream runs
  started from rest after the first; the target is none),
- the streaming time against the planned time (`motet run` of the file),
- how long `?` takes to answer while the machine runs (pyserial, one `?`
  at a time, after the stream),
- how soon a feed hold (`!`) brakes, from the session's event log.

Measured, printed, never asserted:

    target/pyenv/bin/python bench/grbl_stream.py [LINES] [FEED_MM_MIN]

Needs `target/debug/motet` (or MOTET=path) and pygrbl-streamer and pyserial
in target/pyenv (`./scripts/test` installs them).
"""

import math
import os
import statistics
import sys
import tempfile
import time

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "crates", "motet-serve", "tests", "python"))

import serial  # noqa: E402
from grbl_common import ROOT, Server, reference  # noqa: E402
from pygrbl_streamer import GrblStreamer  # noqa: E402

MACHINE = os.path.join(ROOT, "examples", "laser.toml")


def arcs(n, feed):
    cx, cy, r, step = 200.0, 150.0, 20.0, math.radians(2.0)
    lines = ["G21 G90", f"G0 X{cx + r:.4f} Y{cy:.4f}", f"F{feed}"]
    a = 0.0
    for _ in range(n):
        x0, y0 = cx + r * math.cos(a), cy + r * math.sin(a)
        a += step
        x1, y1 = cx + r * math.cos(a), cy + r * math.sin(a)
        lines.append(f"G3 X{x1:.4f} Y{y1:.4f} I{cx - x0:.4f} J{cy - y0:.4f}")
    return "\n".join(lines) + "\n"


def status_latency(srv, samples=200):
    """`?` answered while a long move runs, seconds each; then a feed hold."""
    times = []
    with serial.Serial(srv.pty, 115200, timeout=1) as s:
        s.write(b"\x18")
        time.sleep(0.3)
        s.reset_input_buffer()
        s.write(b"$X\nG90 G1 X10 Y10 F3000\n")
        replies = 0
        while replies < 2:
            line = s.readline()
            replies += line.startswith(b"ok") or line.startswith(b"error")
        for _ in range(samples):
            t = time.perf_counter()
            s.write(b"?")
            line = s.readline()
            times.append(time.perf_counter() - t)
            assert line.startswith(b"<"), line
            time.sleep(0.005)
        s.write(b"!")
        time.sleep(0.5)
        s.write(b"?")
        print("after the hold:", s.readline().decode().strip())
        s.write(b"\x18")
        time.sleep(0.3)
    return times


def main():
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 20_000
    feed = int(sys.argv[2]) if len(sys.argv) > 2 else 12_000
    path = os.path.join(tempfile.mkdtemp(), "arcs.gcode")
    with open(path, "w") as f:
        f.write(arcs(n, feed))
    planned = reference(MACHINE, path)["duration_s"]
    with Server(MACHINE) as srv:
        g = GrblStreamer(srv.pty)
        g.connect()
        t = time.monotonic()
        ok = g.send_file(path, completion_timeout=3600)
        took = time.monotonic() - t
        g.disconnect()
        runs = srv.stream_runs()
        events = srv.get("/api/events?since=0")
        first = next(e["t_us"] for e in events if e["message"].startswith("stream run "))
        last = max(e["t_us"] for e in events if e["message"] == "streamed commands run, at rest")
        moving = (last - first) * 1e-6
        lat = status_latency(srv)
        holds = [e["message"] for e in srv.get("/api/events?since=0") if e["message"].startswith("feed hold: braking")]
    print(f"file: {n} arcs of 2° on a 20 mm circle at F{feed}, {os.path.getsize(path)} bytes")
    print(
        f"streamed: {'completed' if ok else 'FAILED'} in {took:.1f} s with the sender's connect and idle wait; "
        f"machine time from the first run's start to rest {moving:.2f} s (planned by motet run: {planned:.2f} s)"
    )
    print(f"stops at rest between moves: {max(runs - 1, 0)} ({runs} stream run(s) from rest)")
    lat_ms = sorted(x * 1e3 for x in lat)
    print(
        f"'?' answered in {statistics.median(lat_ms):.2f} ms median, "
        f"{lat_ms[int(len(lat_ms) * 0.99) - 1]:.2f} ms 99th percentile, {lat_ms[-1]:.2f} ms worst ({len(lat_ms)} polls)"
    )
    for h in holds:
        print(h)


if __name__ == "__main__":
    main()
