"""The Python API drives the simulated machine the way the Rust API does."""
import math
import os
import pathlib
import sys
import time

import pytest

import motet

ROOT = pathlib.Path(__file__).resolve().parents[3]
PLOTTER = str(ROOT / "examples" / "plotter.toml")
PRINTER = str(ROOT / "examples" / "printer.toml")


def test_square_ends_where_asked():
    with motet.Machine(PLOTTER) as m:
        m.move_to(x=20, y=20)
        m.set_tool("pen", 1.0)
        for x, y in [(80, 20), (80, 80), (20, 80), (20, 20)]:
            m.move_to(x=x, y=y, feed=60)
        m.set_tool("pen", 0.0)
    assert m.position["x"] == pytest.approx(20, abs=0.01)
    assert m.position["y"] == pytest.approx(20, abs=0.01)
    r = m.report()
    assert r["underruns"] == 0
    assert r["tool_on_distance_mm"] == pytest.approx(240, rel=1e-9)
    assert r["max_deviation_steps"] <= 0.5 + 1e-6


@pytest.mark.parametrize(
    "call, error",
    [
        (lambda m: m.move_to(x=1000), motet.UnreachableError),
        (lambda m: m.move_to(q=1), motet.UnknownNameError),
        (lambda m: m.set_tool("laser", 1), motet.UnknownNameError),
        (lambda m: m.move_to(x=10, feed=-1), motet.ValueOutOfRangeError),
        (lambda m: m.dwell(-1), motet.ValueOutOfRangeError),
        (lambda m: m.set_tool("pen", 2), motet.ValueOutOfRangeError),
    ],
)
def test_refused_calls_raise_and_keep_the_queue(call, error):
    m = motet.Machine(PLOTTER)
    m.move_to(x=50, y=50, feed=100)
    before = m.target
    with pytest.raises(error):
        call(m)
    assert m.target == before
    m.wait()
    assert m.position["x"] == pytest.approx(50, abs=0.01)


def test_bad_machine_file_names_its_place(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text('name = "m"\n[axes.x]\ntravel = [0, 10]\nmax_velocity = "fast"\n')
    with pytest.raises(motet.MachineFileError, match=r"bad.toml:4:"):
        motet.Machine(str(bad))


def test_events_arrive_in_order():
    seen = []
    m = motet.Machine(PLOTTER)
    m.on_event(seen.append)
    m.move_to(x=10, y=10)
    m.set_tool("pen", 1.0)
    m.move_to(x=40)
    m.set_tool("pen", 0.0)
    m.wait()
    kinds = [(e["kind"], e.get("value")) for e in seen]
    assert kinds == [("tool", 1.0), ("tool", 0.0), ("idle", None)]
    assert [e["time"] for e in seen] == sorted(e["time"] for e in seen)


def test_interactive_session_streams(tmp_path):
    # 10,000 moves, each call returning promptly: the machine runs as they come.
    m = motet.Machine(PRINTER)
    m.move_to(x=100, y=100, feed=200)
    longest = 0.0
    for k in range(10_000):
        a = k * 0.05
        t = time.perf_counter()
        m.move_to(x=110 + 40 * math.cos(a), y=110 + 40 * math.sin(a), feed=150)
        longest = max(longest, time.perf_counter() - t)
    assert m.time > 0, "nothing ran before wait()"
    m.wait()
    r = m.report()
    # The stream never ran dry and the machine never had to stop between moves:
    # the only rest is the end.
    assert r["underruns"] == 0
    assert r["rests"] == 1
    m.save(str(tmp_path))
    assert (tmp_path / "path.png").exists()
    print(f"longest call {longest * 1e3:.2f} ms")


def test_trace_edges_and_run_job(tmp_path):
    w, h, lines = motet.trace_edges(str(ROOT / "examples" / "photos" / "portrait.jpg"), max_px=200)
    assert (w, h) == (200, 200)
    assert len(lines) > 20
    assert all(0 <= x <= w and 0 <= y <= h for line in lines for x, y in line)
    with pytest.raises(motet.MotetError):
        motet.trace_edges(str(ROOT / "examples" / "plotter.toml"))
    m = motet.Machine(PLOTTER)
    n = motet.run_job(m, str(ROOT / "examples" / "jobs" / "drawing.svg"))
    assert n > 100
    m.wait()
    assert m.report()["tool_on_distance_mm"] > 1000


@pytest.mark.parametrize("script, args", [
    ("dragon_curve.py", ["8"]),
    ("photo_to_drawing.py", ["examples/photos/portrait.jpg"]),
])
def test_examples_run(tmp_path, script, args):
    import subprocess
    out = tmp_path / "out"
    result = subprocess.run(
        [sys.executable, str(ROOT / "examples" / "python" / script), *args, str(out)],
        cwd=ROOT, capture_output=True, text=True, timeout=300,
    )
    assert result.returncode == 0, result.stderr
    assert (out / "path.png").exists()
    assert "wrote" in result.stdout
