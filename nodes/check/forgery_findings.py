"""What `cavesim check` makes of the forgeries: states served to a resync (forged, or
colliding with the named checksum, from an insider or the source itself), reports in
another wall's name or with forged counts, and session controls under a wall's key."""

from __future__ import annotations

import dataclasses
from pathlib import Path

from nodes.check.evidence import (
    Evidence,
    diverged_at,
    first_divergence,
    none_lost_since,
    refused_meanwhile,
    resynced_at,
)
from nodes.check.state_forgers import COLLIDING, COLLIDING_SOURCE, FORGERIES
from nodes.faults import CONTROL_REQUESTS, RESYNCED, Fault, divergence_frames
from nodes.master.run_record import RunRecord


def state_forgery(fault: Fault, record: RunRecord, harness, killed, out: Path) -> Evidence:
    """Forged snapshots served to a diverged node: detected when it refused them, healed by
    a resync to the state the master named."""
    forged = {f"{kind}-snapshot": harness.forgers.sent[f"{kind}-snapshot"]
              for kind in FORGERIES if harness.forgers.sent.get(f"{kind}-snapshot")}
    refused = refused_meanwhile(harness.measured[str(fault)]).get(fault.node, 0)
    detection = {"forged_snapshots_served": forged, "refused_by_node": refused}
    hit = first_divergence(record, fault)
    if not (hit and refused):
        return Evidence(detection=detection, outcome=f"{fault.node} was not healed")
    healed_at = resynced_at(record, fault.node, hit.frame)
    return Evidence(hit.frame, [fault.node], healed_at, detection,
                    f"{fault.node} loaded only the state the master named"
                    if healed_at is not None else f"{fault.node} was not healed")


def report_forgery(fault: Fault, record: RunRecord, harness, killed, out: Path) -> Evidence:
    """Reports in other walls' names: detected when the master refused them by their
    signer, healed when no report of theirs made a divergence."""
    forged = harness.rogue.sent.get("report-in-another-wall's-name", 0)
    refused = record.master_rejected.get("wrong-signer", 0)
    caught = fault.frame if forged and refused >= forged else None
    judged = diverged_at(record, fault.frame)
    return Evidence(
        caught, healed_at=caught if not judged else None,
        detection={"forged_reports": forged, "refused_by_master_as_wrong_signer": refused},
        outcome=f"no divergence at frame {fault.frame}: no wall was judged by a report it did "
                f"not sign" if not judged else f"walls {judged} were judged at frame "
                                                   f"{fault.frame}")


def collision(fault: Fault, record: RunRecord, harness, killed, out: Path) -> Evidence:
    """A state whose checksum is the named one, served under other walls' keys to a node
    that diverged (the wall asked withholds its first answer, so the twin comes alone):
    detected when the node refused the twin (at least) once per divergence, healed when its
    resync loaded the real state."""
    detection = _collisions_shown(fault, harness, COLLIDING)
    hit = first_divergence(record, fault)
    frames = divergence_frames(fault)  # the first query of each came to a twin alone
    served, refused = detection["colliding_snapshots_served"], detection["refused_by_node"]
    if not (hit and {c["frame"] for c in detection["collisions"]} == set(frames)
            and len(frames) <= min(served, refused)):
        return Evidence(detection=detection, outcome=f"{fault.node} was not shown a collision")
    healed_at = resynced_at(record, fault.node, divergence_frames(fault)[-1])
    return Evidence(hit.frame, [fault.node], healed_at, detection,
                    f"{fault.node} refused each state with the named checksum by its signer "
                    f"and loaded the real one" if healed_at is not None
                    else f"{fault.node} was not healed")


def colliding_source(fault: Fault, record: RunRecord, harness, killed, out: Path
                      ) -> Evidence:
    """The resync's source itself an insider (its key) serving a state with the named
    checksum: detected when the node refused each twin served (the second wall's digest
    differs), healed when, at each divergence, every try from that source failed and the
    next holder's state, confirmed by another wall, was loaded; nothing colliding was ever
    committed (the node diverged at no other frame)."""
    detection = _collisions_shown(fault, harness, COLLIDING_SOURCE)
    frames = divergence_frames(fault)
    tries = {k: [r for r in record.resyncs if r.node == fault.node and r.frame == k]
             for k in frames}
    detection["resyncs"] = [r.to_json() for k in frames for r in tries[k]]
    served, refused = detection["colliding_snapshots_served"], detection["refused_by_node"]
    hit = first_divergence(record, fault)
    source = tries[frames[0]][0].source if tries[frames[0]] else None
    refused_each_time = [c["frame"] for c in detection["collisions"]] == list(frames) \
        and len(frames) == served <= refused
    healed_each_time = all(
        ks and ks[-1].ok and ks[-1].source != source and ks[-1].confirmer is not None
        and not any(r.ok for r in ks if r.source == source) for ks in tries.values())
    planted = [d.frame for d in record.divergences if fault.node in d.nodes
               and fault.frame <= d.frame <= frames[-1] + RESYNCED and d.frame not in frames]
    if not (hit and refused_each_time):
        return Evidence(detection=detection,
                        outcome=f"{fault.node} was not shown the source's collision each time")
    healed = healed_each_time and not planted
    return Evidence(hit.frame, [fault.node], frames[-1] if healed else None, detection,
                    f"{fault.node} refused {source}'s colliding state at each of its "
                    f"{len(frames)} divergences (unconfirmed by a second wall) and loaded the "
                    f"real one from another holder, confirmed" if healed
                    else f"{fault.node} committed a colliding state, or was not healed "
                         f"(divergences at {planted})")


def _collisions_shown(fault: Fault, harness, served_as: str) -> dict:
    """The twins made for `fault`'s divergences, how many were served, and what its node
    refused meanwhile."""
    frames = divergence_frames(fault)
    made = [c for c in harness.forgers.collisions if c["frame"] in frames
            and c["colliding_checksum"] == c["named_checksum"]]
    served = sum(harness.forgers.twins_sent[served_as, k] for k in frames)
    return {"collisions": made, "colliding_snapshots_served": served,
            "refused_by_node": refused_meanwhile(harness.measured[str(fault)]).get(
                fault.node, 0)}


def count_forgery(fault: Fault, record: RunRecord, harness, killed, out: Path) -> Evidence:
    """A wall's report forged with its stolen key (the real checksum, counts far above the
    real ones), reaching the master before the wall's own: detected when the master named
    that wall at the frame with the forged counts as its disputed ones, healed when the
    counts it kept hold none of them and the wall went on in the run (resynced)."""
    forgery = harness.count_forgeries[str(fault)]
    hit = next((d for d in record.divergences
                if d.frame == forgery.frame and fault.node in d.nodes), None)
    disputed = (hit.counters or {}).get(fault.node, {}) if hit else {}
    named = bool(forgery.forged) and all(disputed.get(name, {}).get("values") == values
                                         for name, values in forgery.forged.items())
    kept = _largest_kept(record, forgery.forged)
    clean = named and all(kept.get(name, 0) < min(values)
                          for name, values in forgery.forged.items())
    healed_at = resynced_at(record, fault.node, forgery.frame) \
        if clean and none_lost_since(record, forgery.frame) else None
    return Evidence(
        forgery.frame if named else None, [fault.node] if named else [], healed_at,
        detection={**forgery.summary(), "disputed_at_the_frame": disputed,
                   "largest_kept": kept},
        outcome=f"{fault.node}'s forged counts {forgery.forged} were named and out-voted: "
                f"the run kept the agreed ones (largest {kept})" if clean
        else f"the forged counts of {fault.node} were not both named and left out")


def _largest_kept(record: RunRecord, names) -> dict[str, int]:
    """The largest value the run's counter book kept of each counter of `names`."""
    books = {book.row.name: book for book in record.counters.rows.values()} \
        if record.counters is not None else {}
    return {name: max(n for n, _ in books[name].largest) for name in names if name in books}


def control_forgery(fault: Fault, record: RunRecord, harness, killed, out: Path) -> Evidence:
    """A wall's key asking the master to pause, reset and stop the run, one a frame:
    detected when the master counted each refused as no operator's (`not-an-operator`)
    before the frame it asked for was made, healed when none took effect (no pause, reset
    or stop recorded, no frame held, and the run went on past the last of them)."""
    after_a_kill = killed is not None and record is not killed  # its frames are the new run's
    planned = dataclasses.replace(fault, frame=fault.frame + killed.frames) if after_a_kill \
        else fault
    forged = harness.forged_controls.get(str(planned), [])
    caught = len(forged) == len(CONTROL_REQUESTS) and all(f["refused"] for f in forged)
    obeyed = [action.to_json() for action in record.user_actions]
    went_on = not (obeyed or record.paused_frames or record.user_stopped) \
        and record.frames >= fault.frame + len(CONTROL_REQUESTS) - 1
    return Evidence(
        fault.frame if caught else None,
        healed_at=fault.frame if went_on else None,
        detection={"sent": forged, "refused_by_master_as_not_an_operator":
                   record.master_rejected.get("not-an-operator", 0),
                   "controls_taken": obeyed, "paused_frames": record.paused_frames,
                   "user_stopped": record.user_stopped},
        outcome=f"no control of a wall's key took effect: {record.frames} frames ran, none "
                f"paused or reset, and the run was not stopped" if went_on else
                f"the run obeyed a wall's key: {obeyed}, {record.paused_frames} frame(s) "
                f"paused, stopped: {record.user_stopped}")
