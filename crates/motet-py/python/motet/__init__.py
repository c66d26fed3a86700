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
"""

from ._motet import (
    Machine,
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
    "run_job",
    "trace_edges",
]
