"""How fast Ctrl-C stops a long call of the Python bindings.

Runs the benchmark print through `motet.run_job` (long because of its 197,000
moves), alone and inside a `with` block (whose end must not wait once the block
raised), each in a child process, sends SIGINT at a random moment and measures
the time until the child's `except KeyboardInterrupt` runs (both read
CLOCK_MONOTONIC). `wait()` itself has at most the planner's lookahead and the
nodes' queues to run, a fraction of a second here; it checks for signals the
same way.

    target/pyenv/bin/python bench/python_interrupt.py [ROUNDS]

Needs the bindings installed (`./scripts/test` builds them into target/pyenv).
"""
import pathlib
import random
import signal
import statistics
import subprocess
import sys
import time

ROOT = pathlib.Path(__file__).resolve().parents[1]
PRINTER = ROOT / "examples" / "printer.toml"
JOB = ROOT / "bench" / "data" / "prusaslicer-twisted-vase.gcode.gz"

CHILD = r"""
import sys, time, motet
machine, job, mode = sys.argv[1:]
m = motet.Machine(machine)
print("ready", flush=True)
try:
    if mode == "run_job":
        motet.run_job(m, job)
    else:
        with m:
            motet.run_job(m, job)
    print("finished", flush=True)
except KeyboardInterrupt:
    print(time.monotonic(), m.time, flush=True)
"""


def once(machine, mode, delay):
    child = subprocess.Popen(
        [sys.executable, "-c", CHILD, str(machine), str(JOB), mode],
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        assert child.stdout.readline().strip() == "ready"
        time.sleep(delay)
        sent = time.monotonic()
        child.send_signal(signal.SIGINT)
        out, _ = child.communicate(timeout=600)
    finally:
        child.kill()
    if out.startswith("finished"):
        return None
    caught, simulated = map(float, out.split())
    return caught - sent, simulated


def main():
    rounds = int(sys.argv[1]) if len(sys.argv) > 1 else 10
    random.seed(1)
    for mode in ["run_job", "with"]:
        latencies = []
        for _ in range(rounds):
            r = once(PRINTER, mode, random.uniform(0.2, 2.0))
            if r is None:
                print(f"{mode}: finished before the signal")
                continue
            latencies.append(r[0] * 1e3)
        if latencies:
            print(
                f"{mode:8} SIGINT to KeyboardInterrupt over {len(latencies)} runs: "
                f"median {statistics.median(latencies):.1f} ms, "
                f"max {max(latencies):.1f} ms"
            )


if __name__ == "__main__":
    main()
