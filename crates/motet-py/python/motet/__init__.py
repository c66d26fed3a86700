"""motet: drive a machine directly from Python.

    import motet

    with motet.Machine("examples/plotter.toml") as m:
        m.move_to(x=20, y=30)          # travel at the drawing feed
        m.set_tool("pen", 1.0)         # pen down
        m.move_to(x=80, feed=40)       # draw at 40 mm/s
        m.set_tool("pen", 0.0)
    # leaving the block waits until the machine is at rest

Moves are planned and streamed to the machine's nodes as they are called;
no batch file in between. A call blocks only while the machine's queues are
full. Refused calls raise a subclass of MotetError and leave the queued motion
untouched.

Event callbacks (``on_event``) run after the call that produced the events and
may use the machine; an exception they raise is raised by that call. Ctrl-C
stops any long call with KeyboardInterrupt and leaves the machine usable.
"""

from ._motet import (
    Machine,
    MachineBusyError,
    MachineFileError,
    MotetError,
    UnknownNameError,
    UnreachableError,
    ValueOutOfRangeError,
    run_job,
    trace_edges,
)

__all__ = [
    "Machine",
    "MotetError",
    "MachineFileError",
    "UnreachableError",
    "UnknownNameError",
    "ValueOutOfRangeError",
    "MachineBusyError",
    "run_job",
    "trace_edges",
]
