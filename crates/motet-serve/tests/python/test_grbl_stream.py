"""A grbl sender from PyPI (pygrbl-streamer, character counting) streams a
G-code file to `motet serve --grbl pty`; the machine's path, polled while
it runs, must lie within half a step of the file's path, and it must end
where `motet run` of the same file ends."""

import os
import tempfile

from pygrbl_streamer import GrblStreamer

from grbl_common import ROOT, Poller, Server, distance_to_polyline, reference

MACHINE = os.path.join(ROOT, "examples", "laser.toml")
# The laser's steps per mm (160 on every motor): half a step.
HALF_STEP = 0.5 / 160.0


def job():
    """Straight moves only, so the file's path is exact: a zig-zag of short
    and long lines, with rapids between."""
    pts = [(10.0, 10.0)]
    lines = ["G21 G90", "G0 X10 Y10", "F6000"]
    for k in range(40):
        x = 10.0 + 1.5 * k
        y = 10.0 + (8.0 if k % 2 else 0.0) + 0.37 * k
        lines.append(f"G1 X{x:.3f} Y{y:.3f}")
        pts.append((x, y))
    lines.append("G0 X5 Y5")
    pts.append((5.0, 5.0))
    return "\n".join(lines) + "\n", pts


def test_a_streamed_file_runs_the_path_of_motet_run():
    text, pts = job()
    path = os.path.join(tempfile.mkdtemp(), "zigzag.gcode")
    with open(path, "w") as f:
        f.write(text)
    ref = reference(MACHINE, path)
    with Server(MACHINE) as srv:
        g = GrblStreamer(srv.pty)
        g.connect()
        try:
            with Poller(srv) as poll:
                assert g.send_file(path, stop_on_error=True, completion_timeout=120)
        finally:
            g.disconnect()
        status = srv.get("/api/status")
        runs = srv.stream_runs()
    assert status["state"] == "idle"
    # Where motet run ends, to the step (the first motor of each axis).
    steps = {a["name"]: a for a in ref["actuators"]}
    for axis, motor in (("x", "x_motor"), ("y", "y_left")):
        i = ["x", "y"].index(axis)
        got = round(status["position"][i] * steps[motor]["steps_per_unit"])
        assert got == steps[motor]["position"], (axis, got, steps[motor]["position"])
    moving = [p for s, p, _ in poll.samples if s == "running"]
    assert len(moving) > 50, "the poll saw the machine move"
    start = [(0.0, 0.0)] + pts  # from the machine's start, then the file
    worst = max(distance_to_polyline(p, start) for p in moving)
    assert worst <= HALF_STEP, f"{worst} mm off the file's path"
    print(f"stream runs from rest: {runs}; samples: {len(moving)}; worst distance {worst:.6f} mm")
