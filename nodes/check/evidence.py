"""What the run's record shows of a fault (`Evidence`), and the questions the findings of
`cavesim check` ask of a record: was a node named, resynced, lost since a frame."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from nodes.faults import Fault
from nodes.master.run_record import Divergence, RunRecord


@dataclass(frozen=True)
class Evidence:
    """What a run's record shows of one fault: when the master noticed it (None: never),
    whom it named, when the node was whole again (None: never); for the attacks, what was
    refused (`detection`) and what became of the run (`outcome`); for a bitflip, whether the
    forensics named its particle, field and bit (`localisation`)."""

    detected: int | None = None
    named: list[str] = dataclasses.field(default_factory=list)
    healed_at: int | None = None
    detection: dict = dataclasses.field(default_factory=dict)
    outcome: str = ""
    localisation: dict | None = None


def none_lost_since(record: RunRecord, frame: int) -> bool:
    """Whether the run went past `frame` and lost no wall from then on."""
    return record.frames >= frame and not any(loss.frame >= frame for loss in record.losses)


def diverged_at(record: RunRecord, frame: int) -> list[str]:
    """The walls named by a divergence at `frame`."""
    return sorted({n for d in record.divergences if d.frame == frame for n in d.nodes})


def refused_meanwhile(measured: dict) -> dict[str, int]:
    """Per node, the messages it refused between a fault's two measurements (none without
    the second: the run ended first)."""
    before, after = measured["before"]["refused"], measured.get("after", {}).get("refused", {})
    return {wall: after[wall] - before.get(wall, 0) for wall in after}


def live_at(record: RunRecord, fault: Fault, hit: Divergence | None) -> int | None:
    """The live count of the fault's node after its frame: as its divergence at that frame
    says, else as the run's series does (None if a long run's series skipped that frame)."""
    if hit is not None and hit.frame == fault.frame:
        return hit.particles.get(fault.node)
    series = record.live_particles
    return dict(zip(series.frames(), series, strict=True)).get(fault.frame)


def resynced_at(record: RunRecord, node: str, frame: int) -> int | None:
    return next((r.frame for r in record.resyncs
                 if r.node == node and r.frame >= frame and r.ok), None)


def first_divergence(record: RunRecord, fault: Fault) -> Divergence | None:
    return next((d for d in record.divergences
                 if d.frame >= fault.frame and fault.node in d.nodes), None)
