"""The master's side of a resync: it tells a node to load a healthy member's state of the
frame, whose checksum it names, confirmed by a second member that holds it, and waits for
the node's RESYNCED report (as long as the largest state the scene holds takes to stream,
and RESYNC_MARGIN more). A try that fails (the source's state refused, unconfirmed, or
none came) is followed at once by one from the next holder, confirmed by the one after
(`lockstep.resync_roles`): no single insider among them can plant a state (it may still
make a try fail); a node whose tries fail MAX_RESYNC_FAILURES times in a row is to be given
up until its node joins anew.

What a resync changes in the membership (healed, given up, admitted) is
`nodes/master/process.py`'s; the node's side is `nodes/wall/state_service.py`.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable

from cavesim.core.wire import Command, ControlMessage, ReportMessage
from cavesim.core.wire.snapshot import transfer_seconds
from nodes import lockstep
from nodes.master.run_record import Resync, RunRecord

log = logging.getLogger("cavesim.master")
RESYNC_MARGIN = 5.0  # s beyond a snapshot's transfer: the RESYNC command, the node's report
MAX_RESYNC_FAILURES = 3  # in a row: then the wall is given up until its node joins anew


class Resyncs:
    """The resyncs of one run, and each node's failures in a row."""

    def __init__(self, capacity: int, link, record: RunRecord,
                 pump: Callable[[float], None]) -> None:
        """`link`: the master's (it sends RESYNC); `pump`: handles the master's next event
        until a monotonic deadline (the node's report comes as one)."""
        self.seconds = transfer_seconds(capacity) + RESYNC_MARGIN
        self.link, self.record, self.pump = link, record, pump
        self.failures: dict[str, int] = {}  # wall -> failed resyncs in a row

    def resync(self, k: int, node: str, holders: tuple[str, ...], digest: str,
               reports: dict[str, ReportMessage]) -> bool | None:
        """Have `node` load the state of frame k whose checksum is `digest` from `holders`
        (the members that hold it, the preferred source first), each in turn until one try
        heals it, and wait for its RESYNCED report in `reports` (the frame's, which the
        master's events fill). True: healed; False: failed; None: failed
        MAX_RESYNC_FAILURES times in a row, to be given up."""
        for source, confirmer in lockstep.resync_roles(holders):
            if self._try(k, node, source, confirmer, digest, reports):
                self.failures.pop(node, None)
                return True
            self.failures[node] = failures = self.failures.get(node, 0) + 1
            if failures >= MAX_RESYNC_FAILURES:
                self.failures.pop(node)
                log.warning("frame %d: gave %s up after %d failed resyncs", k, node, failures)
                return None
        return False

    def _try(self, k: int, node: str, source: str, confirmer: str | None, digest: str,
             reports: dict[str, ReportMessage]) -> bool:
        started = time.monotonic()
        reports.pop(node, None)
        self.link.send(ControlMessage(k, Command.RESYNC, node, source, digest,
                                      confirmer=confirmer or ""))
        deadline = started + self.seconds
        ok = None
        while ok is None and time.monotonic() < deadline:
            ok = lockstep.resync_outcome(reports.get(node), digest)
            if ok is None:
                self.pump(deadline)
        self.record.resyncs.append(Resync(k, node, source, bool(ok),
                                          time.monotonic() - started, confirmer))
        return bool(ok)
