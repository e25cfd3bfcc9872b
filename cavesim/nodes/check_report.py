"""What `cavesim check` makes of a run: each fault matched with what the master recorded
(when it was detected, whom it named, when it healed) and, for an attack, what the
harness sent and each side refused (`detection`) and what became of the run (`outcome`).
`harness` is the harness that did the faults (its rogue peer's counts, the nodes that
noticed a killed master, a flood's measurements)."""

from __future__ import annotations

import dataclasses

from cavesim.nodes.faults import FLOOD_MESSAGES, FLOOD_QUERIES, Fault
from cavesim.nodes.record import RunRecord


def check_report(walls: tuple[str, ...], faults: tuple[Fault, ...], record: RunRecord,
                 harness, killed: RunRecord | None) -> dict:
    """check.json's content: per fault its outcome in the plan's frame numbers."""
    summary = record.summary()
    frames = record.frames + (killed.frames if killed is not None else 0)
    outcomes = [_in_plan_frames(fault, record, harness, killed) for fault in faults]
    report = {
        "command": "check",
        "walls": list(walls),
        "frames": frames,
        "faults": outcomes,
        "all_detected": all(o["detected_frame"] is not None for o in outcomes),
        "all_healed": all(o["healed"] for o in outcomes),
        "divergences": record.divergences.total,
        "rogue_messages_sent": dict(harness.rogue.sent) if harness.rogue else {},
        "final": summary["final"],
        "run": summary,
    }
    if killed is not None:
        report["killed_run"] = killed.summary()
    return report


def _in_plan_frames(fault: Fault, record: RunRecord, harness,
                    killed: RunRecord | None) -> dict:
    """`fault`'s outcome in the run it happened in (the killed master's, or the last, whose
    frame 1 is the plan's frame after the killed run's last), its frames the plan's."""
    if killed is None or fault.kind == "master-kill":
        return _outcome(fault, record, harness, killed)
    if fault.frame <= killed.frames:
        return _outcome(fault, killed, harness, killed)
    offset = killed.frames
    outcome = _outcome(dataclasses.replace(fault, frame=fault.frame - offset), record,
                       harness, killed)
    shifted = {key: outcome[key] + offset for key in ("detected_frame", "healed_frame")
               if outcome[key] is not None}
    return {**outcome, **shifted, "fault": str(fault), "frame": fault.frame}


def _outcome(fault: Fault, record: RunRecord, harness,
             killed: RunRecord | None) -> dict:
    """When the master noticed `fault`, whom it named, and when the node was whole again;
    for the attacks, what was refused (`detection`) and what became of the run (`outcome`)."""
    detected, named, healed_at, detection, outcome = None, [], None, {}, ""
    node_rejected = sum(record.node_rejected.values())
    if fault.kind in ("bitflip", "seed", "stale", "jitter", "shove"):
        hit = next((d for d in record.divergences
                    if d.frame >= fault.frame and fault.node in d.nodes), None)
        if hit:
            detected, named = hit.frame, list(hit.nodes)
            healed_at = _resynced(record, fault.node, hit.frame)
    elif fault.kind in ("drop", "slow"):
        hit = next((s for s in record.stalls
                    if s.frame == fault.frame and fault.node in s.nodes), None)
        if hit:
            detected, named = hit.frame, sorted(hit.nodes)
            healed_at = fault.frame if record.frames > fault.frame else None
    elif fault.kind == "kill":
        hit = next((loss for loss in record.losses
                    if loss.node == fault.node and loss.frame >= fault.frame - 1), None)
        if hit:
            detected, named = hit.frame, [fault.node]
            healed_at = next((j.frame for j in record.joins
                              if j.node == fault.node and j.frame >= hit.frame),
                             _resynced(record, fault.node, hit.frame))
    elif fault.kind in ("rogue", "replay-attack"):
        detection = {"sent": dict(harness.rogue.sent), "refused_by_nodes": node_rejected,
                     "refused_by_master": dict(record.master_rejected)}
        if node_rejected:
            detected, healed_at = fault.frame, fault.frame
        outcome = (f"{record.frames} frames ran to the end with "
                   f"{record.divergences.total} divergence(s): no replayed or forged message "
                   f"was stepped or obeyed")
    elif fault.kind == "snapshot-forgery":
        forged = {k: n for k, n in harness.rogue.sent.items() if k.endswith("-snapshot")}
        rejected = record.node_rejected.get(fault.node, 0)
        detection = {"forged_snapshots_served": forged, "refused_by_node": rejected}
        hit = next((d for d in record.divergences
                    if d.frame >= fault.frame and fault.node in d.nodes), None)
        if hit and rejected:
            detected, named = hit.frame, [fault.node]
            healed_at = _resynced(record, fault.node, hit.frame)
        outcome = (f"{fault.node} loaded only the state the master named"
                   if healed_at is not None else f"{fault.node} was not healed")
    elif fault.kind == "flood":
        detection = {**harness.flood, "refused_by_nodes": node_rejected}
        if node_rejected >= FLOOD_MESSAGES:
            detected = fault.frame
        if not record.losses and record.frames:
            healed_at = fault.frame
        outcome = (f"{FLOOD_MESSAGES:,} junk messages and {FLOOD_QUERIES:,} unsigned state "
                   f"queries in {harness.flood.get('seconds')} s: counted, logged at a bounded "
                   f"rate, no node lost")
    elif fault.kind == "master-kill":
        rejoined = list(record.final.members) if record.final else []
        detection = {"killed_run": f"{killed.run_id:016x}", "frames_before": killed.frames,
                     "nodes_that_noticed": harness.noticed, "new_run": f"{record.run_id:016x}",
                     "nodes_in_the_new_run": rejoined}
        if len(harness.noticed) == len(record.walls):
            detected, named = fault.frame, list(harness.noticed)
        if set(rejoined) == set(record.walls) and record.frames:
            healed_at = fault.frame
        outcome = (f"a new master took the {len(rejoined)} nodes over from the scene's start "
                   f"and ran {record.frames} more frames")
    result = {"fault": str(fault), "kind": fault.kind, "frame": fault.frame,
              "node": fault.node, "detected_frame": detected, "named": named,
              "healed_frame": healed_at,
              "healed": healed_at is not None and record.agreed_at_the_end()}
    if detection:
        result |= {"detection": detection, "outcome": outcome}
    return result


def _resynced(record: RunRecord, node: str, frame: int) -> int | None:
    return next((r.frame for r in record.resyncs
                 if r.node == node and r.frame >= frame and r.ok), None)
