"""What happens to the master, as typed events: its link to the nodes (and the launcher's
watch over the node processes) puts them in one queue; the master's loop takes them.
Only checked messages of the run become events: refusals are counted by the link."""

from __future__ import annotations

import time
from dataclasses import dataclass, field

from cavesim.core.wire import DisplayMessage, InfoMessage, ReportMessage


@dataclass(frozen=True)
class Reported:
    """A wall's report of a frame (stepped, resynced or repeated), and when the link took
    it (monotonic s: a lag is measured by it, not by when the master got round to it)."""

    report: ReportMessage
    at: float = field(default_factory=time.monotonic)


@dataclass(frozen=True)
class Described:
    """A wall's answer to the info query: the GPU it computes on."""

    info: InfoMessage


@dataclass(frozen=True)
class Displayed:
    """A displaying wall drew or swapped a frame (the swap barrier)."""

    message: DisplayMessage


@dataclass(frozen=True)
class WallUp:
    wall: str


@dataclass(frozen=True)
class WallDown:
    wall: str


@dataclass(frozen=True)
class OtherMaster:
    """The liveliness token of another master of this session appeared: of run `run_id`."""

    run_id: int
    key: str


@dataclass(frozen=True)
class ProcessEnded:
    """A node process this machine started has exited while the run needed it: a failure
    (code other than 0) ends the run; a node that left on its own (its window was closed)
    is a lost wall, which liveliness reports."""

    name: str
    returncode: int
    failure: str  # one line: its exit code, its own last error line, its log


Event = Reported | Described | Displayed | WallUp | WallDown | OtherMaster | ProcessEnded
