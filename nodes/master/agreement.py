"""The master's verdict on one frame: the vote on the members' checksums and counters
(`nodes/lockstep.py`; in the mixed-hardware mode each member's drift from the authority,
`tolerance.py`, whose counters are kept), and for a divergence its record: the log lines,
each disputed counter with both values, and what differs in each odd node's state (desync
forensics, `forensics.py`: divergences/frame_<k>.json beside report.json).

`nodes/master/process.py` carries out what the verdict names: the resyncs and give-ups.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Mapping
from dataclasses import replace
from pathlib import Path

from cavesim.core.counters import BY_ID
from cavesim.core.wire import BlockReply, BlockRequest, ReportMessage
from nodes import lockstep
from nodes.lockstep import Vote
from nodes.master.forensics import (
    ForensicsError,
    Side,
    failed_report,
    investigate,
    write_report,
)
from nodes.master.run_record import Divergence, RunRecord
from nodes.master.tolerance import ToleranceMode

log = logging.getLogger("cavesim.master")

AskBlocks = Callable[[str, BlockRequest], BlockReply | None]


class Agreement:
    """Frame by frame, what the members agree on and who is odd."""

    def __init__(self, record: RunRecord, widths: Mapping[int, int], check_every: int,
                 tolerance: ToleranceMode | None, forensics: Path | None,
                 ask_blocks: AskBlocks) -> None:
        """`widths`: the run's counters (id -> values); `forensics`: the run's folder (None:
        no forensics); `ask_blocks`: the link's block questions."""
        self.record, self.widths = record, widths
        self.check_every, self.tolerance = check_every, tolerance
        self.forensics, self.ask_blocks = forensics, ask_blocks

    def vote(self, k: int, members: tuple[str, ...],
             reports: Mapping[str, ReportMessage]) -> Vote:
        """Frame k's vote on the members' reports, a divergence recorded; counter entries
        the run does not count are counted per wall and skipped."""
        compare = k % self.check_every == 0
        self.record.counters.skip(lockstep.skipped_counters(members, reports, self.widths))
        if self.tolerance is None:
            vote = lockstep.vote(members, reports, compare, self.widths)
        else:
            vote = self.tolerance.vote(k, members, reports, compare)
            vote = replace(vote, counts=lockstep.reported_counts(reports[vote.source],
                                                                  self.widths))
        if vote.named:
            log.warning("frame %d: divergence, odd node(s): %s", k, ", ".join(vote.named))
            disputes = self._disputed_counts(k, vote)
            forensics = self._investigate(k, vote, reports) if self.tolerance is None else None
            self.record.divergences.append(Divergence(
                k, vote.named, vote.agreed, {n: reports[n].digest for n in members},
                {n: reports[n].particles for n in members}, forensics, disputes))
        return vote

    def _disputed_counts(self, k: int, vote: Vote) -> dict[str, dict[str, dict]] | None:
        """Each node whose counters differ from the agreed ones: a line in the log, and per
        counter both values for the divergence record (None: no counter was disputed)."""
        disputed: dict[str, dict[str, dict]] = {}
        for dispute in vote.counts.disputes:
            name = BY_ID[dispute.counter].name
            log.warning("frame %d: %s counted %s %s, the agreed count is %s", k, dispute.node,
                        name, list(dispute.values), list(dispute.agreed))
            disputed.setdefault(dispute.node, {})[name] = {"values": list(dispute.values),
                                                           "agreed": list(dispute.agreed)}
        return disputed or None

    def _investigate(self, k: int, vote: Vote,
                     reports: Mapping[str, ReportMessage]) -> dict | None:
        """What differs between each odd node's state and the agreed one (before the resync
        replaces it): divergences/frame_<k>.json, a line in the log; the file and the
        first odd node's line for the record. None without a folder for the reports, or
        when every odd node holds the agreed state (its counts differed)."""
        odd = [node for node in vote.odd if reports[node].digest != vote.agreed]
        if self.forensics is None or not odd:
            return None
        reference = Side(vote.source, vote.agreed)
        found, started = [], time.monotonic()
        for node in odd:
            side = Side(node, reports[node].digest)
            try:
                report = investigate(k, side, reference, self.ask_blocks)
            except ForensicsError as e:
                report = failed_report(k, side, reference, str(e))
            log.warning("%s", report["summary"])
            found.append(report)
        path = write_report(self.forensics, found[0], found[1:])
        return {"file": str(path.relative_to(self.forensics)),
                "summary": found[0]["summary"],
                "seconds": round(time.monotonic() - started, 4)}
