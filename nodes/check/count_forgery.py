"""The harness's `count-forgery`: an outsider holding one wall's stolen key reports that
wall's frame with the state's real checksum and counts far above what any wall counted (a
report.json that took one wall's word would then say so). The master must keep only the
counts the walls agreed on, name the wall whose report disputed them, and go on.

The forged report must reach the master before the wall's own, and it can only be made
once the frame is out (it carries the real checksum, from another wall's report of that
frame, and a report of a frame not yet sent is refused). So the harness holds the wall's
reply: its process is stopped (SIGSTOP) before the frame is sent, the forgery is sent when
another wall's report is seen, and the wall goes on (SIGCONT) only once the master has
acted on the forgery: its RESYNC of that wall, which needs the forged report in its vote.
Each step waits at most FORGERY_SECONDS; the wall always goes on.
"""

from __future__ import annotations

import dataclasses
import logging
import os
import signal
import threading
import time

from cavesim.core.counters import BY_ID
from cavesim.core.errors import ProtocolError
from cavesim.core.wire import Command, ControlMessage, Credentials, ReportMessage, encode
from cavesim.core.wire.envelope import decode_envelope
from cavesim.core.wire.payloads.from_nodes import Status
from nodes.check.rogue import RoguePeer
from nodes.faults import inflated

log = logging.getLogger("cavesim.check")
FORGERY_SECONDS = 5.0  # s each step may take (under --evict-after: the wall stays a member)
FORGED = "forged-count-report"  # what the rogue peer counts it as


class CountForgery:
    """One count forgery of frame `frame` in the name of the wall `member` holds the key of,
    whose node process is `pid`; `start` it in the harness's hook before that frame."""

    def __init__(self, rogue: RoguePeer, member: Credentials, pid: int, frame: int) -> None:
        self.rogue, self.member, self.pid, self.frame = rogue, member, pid, frame
        self.wall = member.member.name
        self.forged: dict[str, list[int]] = {}  # counter name -> the forged values
        self.real: dict[str, list[int]] = {}  # as the wall whose report was copied counted
        self.copied_from: str | None = None
        self.resynced = False  # the master acted on it before the wall's own report came
        self._since: dict[str, int] = {}  # messages of each kind captured before it
        self._thread = threading.Thread(target=self._forge, daemon=True, name="count forgery")

    def start(self) -> None:
        """Hold the wall (it cannot report the frame about to be sent) and forge."""
        self._since = {kind: self.rogue.captured_count(kind) for kind in ("report", "control")}
        os.kill(self.pid, signal.SIGSTOP)
        self._thread.start()

    def join(self) -> None:
        self._thread.join(2 * FORGERY_SECONDS + 1.0)

    def _forge(self) -> None:
        try:
            deadline = time.monotonic() + FORGERY_SECONDS
            copied = self.rogue.await_captured("report", self._since["report"],
                                               self._another_walls_report, deadline)
            if copied is None:
                log.warning("count forgery: no other wall's report of frame %d came",
                            self.frame)
                return
            report, run_id = copied
            forged = dataclasses.replace(report, node=self.wall,
                                         counters=inflated(report.counters))
            self.copied_from = report.node
            self.real = _by_name(report.counters)
            self.forged = _by_name(forged.counters)
            self.rogue.put(FORGED, self.rogue.keys.report(self.wall),
                           encode(forged, self.rogue.name, self.member, run_id))
            deadline = time.monotonic() + FORGERY_SECONDS
            self.resynced = self.rogue.await_captured(
                "control", self._since["control"], self._its_resync, deadline) is not None
        finally:
            os.kill(self.pid, signal.SIGCONT)

    def _another_walls_report(self, data: bytes) -> tuple[ReportMessage, int] | None:
        """Another wall's report of the frame as it stepped it, and the run id it is of."""
        message, run_id = self._open(data)
        if isinstance(message, ReportMessage) and message.frame == self.frame \
                and message.node != self.wall and message.status is Status.STEPPED:
            return message, run_id
        return None

    def _its_resync(self, data: bytes) -> bool | None:
        """True for the master's RESYNC of the forged wall at the frame."""
        message, _ = self._open(data)
        if isinstance(message, ControlMessage) and message.command is Command.RESYNC \
                and message.target == self.wall and message.frame == self.frame:
            return True
        return None

    def _open(self, data: bytes):
        try:
            envelope = decode_envelope(data, self.rogue.name, self.member)
        except ProtocolError:
            return None, 0
        return envelope.message, envelope.run_id

    def summary(self) -> dict:
        return {"frame": self.frame, "wall": self.wall, "copied_from": self.copied_from,
                "real_counts": self.real, "forged_counts": self.forged,
                "resynced_before_its_own_report": self.resynced}


def _by_name(counters: tuple[tuple[int, tuple[int, ...]], ...]) -> dict[str, list[int]]:
    return {BY_ID[id_].name: list(values) for id_, values in counters if id_ in BY_ID}
