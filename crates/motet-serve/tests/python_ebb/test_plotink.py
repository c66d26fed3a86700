"""The AxiDraw software's board library from PyPI (plotink, its EBB3
class, as the AxiDraw software drives firmware 3) plots an SVG through
`motet serve --ebb pty` on the AxiDraw-like plotter: paths flattened by
plotink's own subdivision, rounded to the AxiDraw's step grid, pen-down
strokes as `LM` rate moves, pen-up travel as `XM`, the pen by `SP`, home
by `HM`. What the machine did is read over HTTP while it plots: every
position lies within half a machine step of the path the step counts
give, and the machine comes to rest at each stroke's two ends within one
AxiDraw step. The board's step counters (`QS`) match the counts, and its
rate moves match plotink's own model of the firmware (`ebb_calc`)."""

import math
import os
import sys
import time

from ink_extensions import cubicsuperpath
from plotink import ebb3_motion, ebb3_serial, ebb_calc, ebb_serial, plot_utils

# The `motet serve` process the adapters' tests share.
sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "python"))
from grbl_common import ROOT, Poller, Server  # noqa: E402
MACHINE = os.path.join(ROOT, "examples", "plotter.toml")
# The AxiDraw's grid: 2032 steps per inch of x or y at 1/16 microstepping.
STEPS_PER_MM = 2032 / 25.4
EBB_STEP = 1 / STEPS_PER_MM
# The plotter's motors: 3200 steps per turn of a 9 mm pulley; half a step.
HALF_STEP = 0.5 * math.pi * 9.0 / 3200
# The SVG: a square and a circle, in mm.
SVG_PATHS = [
    "M 5 5 L 20 5 L 20 20 L 5 20 Z",
    "M 30 12 A 6 6 0 1 0 42 12 A 6 6 0 1 0 30 12 Z",
]
DRAW_MM_S = 40.0
TRAVEL_MM_S = 80.0
# The EBB's rate register per step/s: 2^31 x 40 us.
RATE_PER_HZ = 2**31 * 40e-6


def strokes():
    """The SVG's paths flattened as the AxiDraw software flattens them,
    each vertex rounded to the step grid: lists of (x, y) in steps."""
    out = []
    for d in SVG_PATHS:
        for sp in cubicsuperpath.parsePath(d):
            plot_utils.subdivideCubicPath(sp, 0.02)
            pts = [(round(n[1][0] * STEPS_PER_MM), round(n[1][1] * STEPS_PER_MM)) for n in sp]
            out.append([p for i, p in enumerate(pts) if i == 0 or p != pts[i - 1]])
    return out


def mm(p):
    return (p[0] * EBB_STEP, p[1] * EBB_STEP)


def motors(dx, dy):
    """The AxiDraw's mixing: motor1 = x + y, motor2 = x - y."""
    return dx + dy, dx - dy


def connect(pty):
    """plotink finds a board by its USB name; a pty has none, so the port's
    path is taken as the name it looks for."""
    ebb3_serial.find_named = lambda name: name
    ebb = ebb3_motion.EBBMotionWrap()
    assert ebb.connect(pty), ebb.err
    return ebb


def plot(ebb, paths):
    """Moves as the AxiDraw software sends them; returns the motor step
    totals and the reference path (mm) from home."""
    at = (0, 0)
    total = [0, 0]
    path = [mm(at)]
    for stroke in paths:
        # Pen-up travel: XM (A = x, B = y).
        dx, dy = stroke[0][0] - at[0], stroke[0][1] - at[1]
        ms = max(1, round(math.hypot(dx, dy) * EBB_STEP / TRAVEL_MM_S * 1000))
        ebb.command(f"XM,{ms},{dx},{dy}")
        m1, m2 = motors(dx, dy)
        total = [total[0] + m1, total[1] + m2]
        at = stroke[0]
        path.append(mm(at))
        ebb.pen_lower(150)
        for p in stroke[1:]:
            m1, m2 = motors(p[0] - at[0], p[1] - at[1])
            t = math.hypot(p[0] - at[0], p[1] - at[1]) * EBB_STEP / DRAW_MM_S
            r1 = round(RATE_PER_HZ * abs(m1) / t)
            r2 = round(RATE_PER_HZ * abs(m2) / t)
            ebb.command(f"LM,{r1},{m1},0,{r2},{m2},0,3")
            total = [total[0] + m1, total[1] + m2]
            at = p
            path.append(mm(at))
        ebb.pen_raise(150)
    assert ebb.err is None, ebb.err
    return total, path


def wait_idle(ebb, srv):
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        busy = ebb.query_statusbyte() & 0x0F
        if not busy and srv.get("/api/status")["state"] == "idle":
            return
        time.sleep(0.05)
    raise AssertionError("the plot did not end")


def distance_to_polyline(p, pts):
    best = math.inf
    for (ax, ay), (bx, by) in zip(pts, pts[1:]):
        dx, dy = bx - ax, by - ay
        l2 = dx * dx + dy * dy
        t = 0.0 if l2 == 0 else max(0.0, min(1.0, ((p[0] - ax) * dx + (p[1] - ay) * dy) / l2))
        best = min(best, math.hypot(p[0] - ax - t * dx, p[1] - ay - t * dy))
    return best


def test_plotink_plots_an_svg_with_the_axidraw_steps():
    paths = strokes()
    assert len(paths) == 2 and len(paths[1]) > 20, "a square and a flattened circle"
    started = time.monotonic()
    with Server(MACHINE, device="ebb") as srv:
        # The older functions find the board by a port path too.
        legacy = ebb_serial.testPort(srv.pty)
        assert legacy is not None and ebb_serial.min_version(legacy, "3.0.2")
        ebb_serial.closePort(legacy)
        ebb = connect(srv.pty)
        assert ebb.version == "3.0.3"
        ebb.motors_enable(1, 1)
        ebb.clear_steps()
        with Poller(srv) as poll:
            total, path = plot(ebb, paths)
            wait_idle(ebb, srv)
            assert ebb.query_steps() == tuple(total), "QS counts every step"
            ebb.abs_move(4000)  # HM: home, as the AxiDraw ends a plot
            path.append((0.0, 0.0))
            wait_idle(ebb, srv)
        assert ebb.query_steps() == (0, 0)
        end = srv.get("/api/status")
        rate_moves = check_rate_moves(ebb, srv)
        ebb.disconnect()
    assert end["state"] == "idle"
    assert math.hypot(*end["position"]) < 1e-9, end["position"]
    moving = [(p, v) for s, p, v in poll.samples if s == "running"]
    assert len(moving) > 100, "the poll saw the machine move"
    worst = max(distance_to_polyline(p, path) for p, _ in moving)
    assert worst <= HALF_STEP, f"{worst} mm off the path of the step counts"
    # Each stroke's ends: the machine rests there while the pen moves.
    resting = [p for p, v in moving if v == 0.0]
    for stroke in paths:
        for end_pt in (mm(stroke[0]), mm(stroke[-1])):
            gap = min(math.hypot(p[0] - end_pt[0], p[1] - end_pt[1]) for p in resting)
            assert gap <= EBB_STEP, f"no rest within a step of stroke end {end_pt}: {gap}"
    print(
        f"strokes {len(paths)}, moves {sum(len(s) for s in paths)}, samples {len(moving)}, "
        f"worst {worst:.2e} mm, rate moves {rate_moves}, {time.monotonic() - started:.1f} s"
    )


def check_rate_moves(ebb, srv):
    """LM, LT and T3 moves with acceleration and reversal: the counters
    after them are those plotink's model of the firmware predicts."""
    moves = [
        ("LM", (40000000, 300, 20000, 30000000, -200, 0)),
        ("LM", (60000000, 250, -30000, 20000000, 100, 10000)),
        ("LT", (2500, 50000000, -20000, -30000000, 12000)),
        ("T3", (2000, 20000000, 30000, 20, -40000000, 0, 0)),
    ]
    ebb.clear_steps()
    want = [0, 0]
    for name, v in moves:
        ebb.command(f"{name},{','.join(map(str, v))},3")
        if name == "LM":
            for k in range(2):
                want[k] += ebb_calc.calculate_lm(v[3 * k + 1], v[3 * k], v[3 * k + 2])[1]
        elif name == "LT":
            want[0] += ebb_calc.move_dist_lt(v[1], v[2], v[0])[0]
            want[1] += ebb_calc.move_dist_lt(v[3], v[4], v[0])[0]
        else:
            want[0] += ebb_calc.move_dist_t3(v[0], v[1], v[2], v[3])[0]
            want[1] += ebb_calc.move_dist_t3(v[0], v[4], v[5], v[6])[0]
    assert ebb.err is None, ebb.err
    wait_idle(ebb, srv)
    assert ebb.query_steps() == tuple(want)
    return len(moves)
