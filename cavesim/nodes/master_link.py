"""The master's side of the wire over Zenoh: typed events in, messages out.

Zenoh callbacks only decode, check and enqueue (the master's loop does the work): reports
and info answers must come from the wall their key names, tracking messages must be
tracking messages, and liveliness tokens of the session's walls become WallUp/WallDown.
"""

from __future__ import annotations

import logging
import queue
from collections.abc import Iterator
from contextlib import contextmanager

import zenoh

from cavesim.core.errors import ProtocolError
from cavesim.core.wire import (
    ControlMessage,
    DisplayMessage,
    FrameMessage,
    InfoMessage,
    ReportMessage,
    SessionKeys,
    TrackingMessage,
    decode,
    encode,
)
from cavesim.core.wire.network import lockstep_publisher, open_session
from cavesim.nodes.events import (
    Described,
    Displayed,
    Event,
    Rejected,
    Reported,
    Tracked,
    WallDown,
    WallUp,
)

log = logging.getLogger("cavesim.master")
INFO_TIMEOUT = 10.0  # s a wall has to say which GPU it computes on


class ZenohMasterLink:
    def __init__(self, session: zenoh.Session, name: str, key: bytes | None,
                 walls: tuple[str, ...]) -> None:
        self.session, self.name, self.key, self.walls = session, name, key, walls
        self.keys = SessionKeys(name)
        self.events: queue.Queue[Event] = queue.Queue()
        self._frames = lockstep_publisher(session, self.keys.frame)
        self._control = lockstep_publisher(session, self.keys.control)
        self._declarations = [
            session.declare_subscriber(self.keys.report(), self._on_report),
            session.declare_subscriber(self.keys.display(), self._on_display),
            session.declare_subscriber(self.keys.tracking, self._on_tracking),
            session.liveliness().declare_subscriber(self.keys.alive(), self._on_alive,
                                                    history=True),
        ]

    def send(self, message: FrameMessage | ControlMessage) -> None:
        publisher = self._frames if isinstance(message, FrameMessage) else self._control
        publisher.put(encode(message, self.name, self.key))

    def ask_info(self, wall: str) -> None:
        """Ask `wall` which GPU it computes on; the answer arrives as an event."""
        self.session.get(self.keys.info(wall), self._on_info, timeout=INFO_TIMEOUT)

    def close(self) -> None:
        for declaration in reversed(self._declarations):
            declaration.undeclare()

    # -- zenoh callbacks: decode, check, enqueue ------------------------------------------

    def _on_alive(self, sample: zenoh.Sample) -> None:
        wall = self.keys.node_of(sample.key_expr)
        if wall in self.walls:
            up = sample.kind == zenoh.SampleKind.PUT
            self.events.put(WallUp(wall) if up else WallDown(wall))

    def _on_report(self, sample: zenoh.Sample) -> None:
        self._from_wall(sample, ReportMessage, Reported, "report")

    def _on_display(self, sample: zenoh.Sample) -> None:
        self._from_wall(sample, DisplayMessage, Displayed, "display")

    def _on_info(self, reply: zenoh.Reply) -> None:
        if reply.ok is None:
            log.warning("an info query failed: %s", reply.err.payload.to_string())
            return
        self._from_wall(reply.ok, InfoMessage, Described, "info")

    def _on_tracking(self, sample: zenoh.Sample) -> None:
        message = self._decode(sample)
        if isinstance(message, TrackingMessage):
            self.events.put(Tracked(message))
        elif message is not None:
            self._reject("unexpected", f"a {type(message).__name__} on the tracking key",
                         sample)

    def _from_wall(self, sample: zenoh.Sample, expected: type, event: type, key: str) -> None:
        message = self._decode(sample)
        if message is None:
            return
        sender = self.keys.node_of(sample.key_expr)
        if not isinstance(message, expected) or message.node != sender \
                or sender not in self.walls:
            self._reject("unexpected", f"{type(message).__name__} from {sender!r} on a "
                                       f"{key} key", sample)
            return
        self.events.put(event(message))

    def _decode(self, sample: zenoh.Sample):
        try:
            return decode(sample.payload.to_bytes(), self.name, self.key)
        except ProtocolError as e:
            self.events.put(Rejected(e, str(sample.key_expr)))
            return None

    def _reject(self, reason: str, detail: str, sample: zenoh.Sample) -> None:
        self.events.put(Rejected(ProtocolError(reason, detail), str(sample.key_expr)))


@contextmanager
def open_master_link(config) -> Iterator[ZenohMasterLink]:
    """A Zenoh session with the master's declarations, for the length of a run."""
    with open_session(config.network) as session:
        link = ZenohMasterLink(session, config.session, config.key, config.walls)
        try:
            yield link
        finally:
            link.close()
