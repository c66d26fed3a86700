"""Ctrl-C stops long calls and leaves the machine usable; save() makes no
missing parents."""
import gzip
import pathlib
import signal
import subprocess
import sys
import time

import pytest

import motet

ROOT = pathlib.Path(__file__).resolve().parents[3]
PRINTER = str(ROOT / "examples" / "printer.toml")
# A 2.2-hour print: long because of its 197,000 moves, not of any pause.
VASE = str(ROOT / "bench" / "data" / "prusaslicer-twisted-vase.gcode.gz")

CHILD = r"""
import sys, motet
machine, job, mode = sys.argv[1:]
m = motet.Machine(machine)
print("ready", flush=True)
try:
    if mode == "call":
        motet.run_job(m, job)
    else:
        with m:
            motet.run_job(m, job)
    print("finished", flush=True)
except KeyboardInterrupt:
    print(m.report()["commands"], flush=True)
    near = lambda a, b: all(abs(a[k] - b[k]) < 0.01 for k in ("x", "y"))
    # Leaving the with block did not wait: the machine is mid-job.
    print("at rest" if near(m.position, m.target) else "moving", flush=True)
    # The machine is usable: what was queued runs to its end.
    t = m.time
    m.wait()
    print("usable" if near(m.position, m.target) and m.time > t else "broken", flush=True)
"""


@pytest.mark.parametrize("mode", ["call", "with"])
def test_ctrl_c_stops_a_long_job_and_leaves_the_machine_usable(mode):
    child = subprocess.Popen(
        [sys.executable, "-c", CHILD, PRINTER, VASE, mode],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        assert child.stdout.readline().strip() == "ready"
        time.sleep(1.0)  # well into the job, which takes several seconds
        child.send_signal(signal.SIGINT)
        out, err = child.communicate(timeout=120)
    finally:
        child.kill()
    commands, *rest = out.split()
    assert rest == ["moving", "usable"], (out, err)
    # Stopped partway: the rest of the job was never queued.
    with gzip.open(VASE, "rt") as f:
        lines = sum(1 for _ in f)
    assert 0 < int(commands) < 0.9 * lines, (commands, lines)


def test_other_threads_run_while_a_call_works():
    import threading

    stamps = []
    done = threading.Event()

    def count():
        while not done.is_set():
            stamps.append(time.monotonic())

    m = motet.Machine(PRINTER)
    worker = threading.Thread(target=count)
    worker.start()
    try:
        start = time.monotonic()
        motet.run_job(m, str(ROOT / "examples" / "jobs" / "printer-vase-layers.gcode"))
        m.wait()
        end = time.monotonic()
    finally:
        done.set()
        worker.join()
    # The GIL is released while the machine works: the other thread ran in
    # the middle of the call, not only before and after it.
    margin = (end - start) / 4
    assert any(start + margin < t < end - margin for t in stamps)


def test_save_makes_its_folder_but_no_missing_parent(tmp_path):
    m = motet.Machine(PRINTER)
    m.move_to(x=20, y=20, feed=100)
    m.wait()
    missing = tmp_path / "missing"
    with pytest.raises(motet.MotetError, match=f"the directory {missing} does not exist"):
        m.save(str(missing / "dir" / "x"))
    assert not missing.exists()
    m.save(str(tmp_path / "out"))
    assert (tmp_path / "out" / "report.json").exists()
