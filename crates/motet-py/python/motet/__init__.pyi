from types import TracebackType
from typing import Any, Callable, Dict, List, Optional, Tuple, Type

class MotetError(Exception):
    """Base class of motet's errors."""

class MachineFileError(MotetError):
    """The machine file is invalid; the message names file:line:column."""

class UnreachableError(MotetError):
    """The target is beyond travel or cannot be reached by the kinematics."""

class UnknownNameError(MotetError):
    """No axis or tool has that name."""

class ValueOutOfRangeError(MotetError):
    """A feed, dwell or tool value is out of range."""

class MachineBusyError(MotetError):
    """The Machine was used while one of its own calls was still working: from
    a signal handler or a finalizer that ran during that call. (Event
    callbacks run after the call's work and may use the machine.)"""

class Machine:
    """A machine driven call by call, on simulated nodes.

    Calls that let time pass (moves waiting for queue room, wait, run_job,
    save) release the GIL while they work and stop within milliseconds on
    Ctrl-C with KeyboardInterrupt. The machine stays usable afterwards:
    nothing accepted is lost or run twice. A move whose call was interrupted
    was accepted (``target`` includes it); a job interrupted in run_job is
    queued up to that point; ``wait()`` runs whatever is queued.

    Event callbacks run after the work of the call that produced the events,
    in order; they may read and drive the machine (even wait for it). An
    exception a callback raises is raised by that call, with its traceback,
    after the call's own work is done; events not yet delivered come with the
    next call."""

    def __init__(self, path: str) -> None:
        """Opens the machine described by a machine file (TOML)."""
    @property
    def axes(self) -> List[str]:
        """Axis names, in order."""
    @property
    def tools(self) -> List[str]:
        """Tool names."""
    def move_to(self, feed: Optional[float] = None, **axes: float) -> None:
        """Move the named axes to absolute positions, e.g. move_to(x=10, y=20, feed=50).

        feed is in units per second; without it, the machine's drawing feed."""
    def rapid_to(self, **axes: float) -> None:
        """Move the named axes to absolute positions as fast as the limits allow."""
    def jog(self, feed: Optional[float] = None, **axes: float) -> None:
        """Move the named axes by the given amounts, e.g. jog(x=-5)."""
    def set_tool(self, tool: str, value: float) -> None:
        """Set a tool output: pen 1 down / 0 up, laser or spindle power 0..1."""
    def dwell(self, seconds: float) -> None:
        """Stand still for `seconds` after the motion queued before."""
    def wait(self) -> None:
        """Block until everything queued has run and the machine is at rest,
        including motion that event callbacks queue meanwhile."""
    @property
    def position(self) -> Dict[str, float]:
        """Where the motors are now, by axis name."""
    @property
    def target(self) -> Dict[str, float]:
        """Where the machine will be after everything queued, by axis name."""
    @property
    def time(self) -> float:
        """Simulated time in seconds."""
    def on_event(self, callback: Callable[[Dict[str, Any]], None]) -> None:
        """Call callback(event) for every event from now on: a dict with kind
        ("tool" or "idle"), time (s) and, for tools, tool and value.

        Callbacks run after the call that produced the event and may use the
        machine; an exception they raise is raised by that call."""
    def report(self) -> Dict[str, Any]:
        """The run report: duration, distances, steps, peaks against limits, accuracy."""
    def save(self, directory: str) -> None:
        """Write path.png, path.svg and report.json of everything executed so far
        into directory, which is made if missing; a missing parent is an error
        (MotetError naming it), not made."""
    def __enter__(self) -> "Machine": ...
    def __exit__(
        self,
        exc_type: Optional[Type[BaseException]],
        exc: Optional[BaseException],
        tb: Optional[TracebackType],
    ) -> bool:
        """Waits for the machine to finish, unless the block raised (Ctrl-C
        included): then the exception goes on at once and the queued motion
        stays queued."""

def trace_edges(
    path: str,
    max_px: int = 400,
    blur_sigma: float = 1.5,
    min_length_px: int = 8,
    simplify_px: float = 0.8,
) -> Tuple[int, int, List[List[Tuple[float, float]]]]:
    """Edges of a photograph (PNG or JPEG) as polylines.

    Decodes, converts to grayscale, resizes so the longest side is max_px, blurs,
    finds Canny edges, thins them, traces edge pixels into polylines, drops
    chains shorter than min_length_px and simplifies within simplify_px.
    Returns (width_px, height_px, polylines); points are (x, y) in pixels with
    y pointing down."""

def run_job(machine: Machine, path: str, allow_unknown: bool = False) -> int:
    """Read a job file (G-code, SVG or photo), check it against the machine and
    queue all of it, as `motet run` does. Returns the number of commands.

    Ctrl-C stops it with KeyboardInterrupt; the commands queued until then
    stay queued (``target`` is where they end), the rest of the job is not."""
