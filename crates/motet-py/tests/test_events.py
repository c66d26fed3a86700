"""Event callbacks: their exceptions propagate, and they may use the machine."""
import pathlib

import pytest

import motet

ROOT = pathlib.Path(__file__).resolve().parents[3]
PLOTTER = str(ROOT / "examples" / "plotter.toml")


def pen_strokes(m):
    """Two pen strokes: four tool events, then idle once waited for."""
    m.move_to(x=10, y=10)
    m.set_tool("pen", 1.0)
    m.move_to(x=40)
    m.set_tool("pen", 0.0)
    m.move_to(x=60)
    m.set_tool("pen", 1.0)
    m.move_to(y=40)
    m.set_tool("pen", 0.0)


EXPECTED = [("tool", 1.0), ("tool", 0.0), ("tool", 1.0), ("tool", 0.0), ("idle", None)]


def kinds(events):
    return [(e["kind"], e.get("value")) for e in events]


def run_until_done(m, calls):
    """Runs the calls, then waits until a wait returns; gives the callbacks'
    exceptions and the number of waits (each ends in an idle event)."""
    raised = []
    for call in calls:
        try:
            call(m)
        except ValueError as e:
            raised.append(e)
    waits = 0
    while True:
        waits += 1
        try:
            m.wait()
            return raised, waits
        except ValueError as e:
            # Events left undelivered come with the next call.
            raised.append(e)


# (events on which the first callback raises)
@pytest.mark.parametrize("failing", [[0], [1, 2], [0, 1, 2, 3, 4]])
def test_a_callback_error_is_raised_by_the_call_and_loses_no_event(failing):
    first, second = [], []

    def fussy(e):
        first.append(e)
        if len(first) - 1 in failing:
            raise ValueError(f"event {len(first) - 1} refused")

    m = motet.Machine(PLOTTER)
    m.on_event(fussy)
    m.on_event(second.append)
    calls = [
        lambda m: m.move_to(x=10, y=10),
        lambda m: m.set_tool("pen", 1.0),
        lambda m: m.move_to(x=40),
        lambda m: m.set_tool("pen", 0.0),
        lambda m: m.move_to(x=60),
        lambda m: m.set_tool("pen", 1.0),
        lambda m: m.move_to(y=40),
        lambda m: m.set_tool("pen", 0.0),
    ]
    raised, waits = run_until_done(m, calls)
    assert [str(e) for e in raised] == [f"event {k} refused" for k in failing]
    # Every callback saw every event once, in order, raising or not.
    expected = EXPECTED[:-1] + [("idle", None)] * waits
    assert kinds(first) == expected
    assert kinds(second) == expected
    assert m.position["x"] == pytest.approx(60, abs=0.01)


def test_the_callback_error_keeps_its_traceback():
    def callback_that_fails(e):
        raise KeyError("from the callback")

    m = motet.Machine(PLOTTER)
    m.on_event(callback_that_fails)
    with pytest.raises(KeyError, match="from the callback") as info:
        pen_strokes(m)
        m.wait()
    assert any(entry.name == "callback_that_fails" for entry in info.traceback)


def test_callbacks_may_use_the_machine():
    m = motet.Machine(PLOTTER)
    seen = []

    def look(e):
        # Reading the machine from inside its callback.
        seen.append((e["kind"], m.time >= e["time"] - 1e-9, dict(m.position), m.tools))

    more = []

    def go_on(e):
        # Driving it: after the first rest, one more stroke; wait() runs it too.
        if e["kind"] == "idle" and not more:
            more.append(e["time"])
            m.move_to(x=5, y=5, feed=100)
            m.dwell(0.1)

    m.on_event(look)
    m.on_event(go_on)
    pen_strokes(m)
    m.wait()
    assert [k for k, *_ in seen] == [k for k, _ in EXPECTED] + ["idle"]
    assert all(later for _, later, _, _ in seen)
    assert all(tools == ["pen"] for *_, tools in seen)
    assert m.position["x"] == pytest.approx(5, abs=0.01)
    assert m.time > more[0] + 0.1


def test_a_callback_may_wait_for_the_machine():
    m = motet.Machine(PLOTTER)
    order = []
    waited = []

    def nested(e):
        order.append(e["kind"])
        if len(order) == 1:
            # Re-entrant: runs everything queued and delivers the events
            # after this one before it returns.
            m.wait()
            waited.append((len(order), m.position["y"]))

    m.on_event(nested)
    pen_strokes(m)
    m.wait()
    # The nested wait ran the rest of the strokes and delivered their events
    # (and the outer wait's rest, if it had come already) before returning.
    assert len(waited) == 1
    delivered, y = waited[0]
    assert delivered >= len(EXPECTED) and y == pytest.approx(40, abs=0.01)
    tools = len(EXPECTED) - 1
    assert order[:tools] == ["tool"] * tools
    assert order[tools:] == ["idle", "idle"]  # one rest for each wait


def test_a_signal_handler_using_the_busy_machine_gets_a_clear_error():
    import signal

    m = motet.Machine(str(ROOT / "examples" / "printer.toml"))

    def handler(signum, frame):
        m.position  # the machine is in the middle of run_job

    old = signal.signal(signal.SIGALRM, handler)
    signal.setitimer(signal.ITIMER_REAL, 0.2)
    try:
        with pytest.raises(motet.MachineBusyError, match="in the middle of a call"):
            motet.run_job(m, str(ROOT / "bench" / "data" / "prusaslicer-twisted-vase.gcode.gz"))
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)
    # Usable again: the call is over, so the machine answers (the alarm may
    # have come while the job was still being read, before any motion).
    assert m.time >= 0 and m.target is not None
