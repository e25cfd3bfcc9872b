"""What `cavesim check` makes of a run: each fault matched with what the master recorded
(when it was detected, whom it named, when it healed) and, for an attack, what the
harness sent and each side refused (`detection`) and what became of the run (`outcome`).
`harness` is the harness that did the faults (its rogue peer's counts, the nodes that
noticed a killed master, a flood's measurements). A `bitflip` must also be localised: the
divergence's forensic report (divergences/frame_<k>.json in `out`) must name exactly the
particle, the field and the bit the node flipped (`bitflip_target` of the live count)."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

from cavesim.core.record_diff import field_bit
from cavesim.core.records import PARTICLE_DTYPE
from nodes.faults import FLOOD_MESSAGES, FLOOD_QUERIES, Fault, bitflip_target
from nodes.master.run_record import Divergence, RunRecord


def check_report(walls: tuple[str, ...], faults: tuple[Fault, ...], record: RunRecord,
                 harness, killed: RunRecord | None, out: Path) -> dict:
    """check.json's content: per fault its outcome in the plan's frame numbers; `out` is
    the run's folder (its divergences/ reports)."""
    summary = record.summary()
    frames = record.frames + (killed.frames if killed is not None else 0)
    outcomes = [_in_plan_frames(fault, record, harness, killed, out) for fault in faults]
    report = {
        "command": "check",
        "walls": list(walls),
        "frames": frames,
        "faults": outcomes,
        "all_detected": all(o["detected_frame"] is not None for o in outcomes),
        "all_healed": all(o["healed"] for o in outcomes),
        "all_localised": all(o["localisation"]["exact"] for o in outcomes
                             if "localisation" in o),
        "divergences": record.divergences.total,
        "rogue_messages_sent": dict(harness.rogue.sent) if harness.rogue else {},
        "final": summary["final"],
        "run": summary,
    }
    if killed is not None:
        report["killed_run"] = killed.summary()
    return report


def check_passed(report: dict, injected: bool) -> bool:
    """The harness's verdict: every wall agrees at the end, and every fault was detected,
    healed and (a bitflip) localised exactly; a run without faults must not diverge."""
    return bool(report["final"].get("agree") and report["all_detected"]
                and report["all_healed"] and report["all_localised"]
                and (injected or report["divergences"] == 0))


def _in_plan_frames(fault: Fault, record: RunRecord, harness,
                    killed: RunRecord | None, out: Path) -> dict:
    """`fault`'s outcome in the run it happened in (the killed master's, or the last, whose
    frame 1 is the plan's frame after the killed run's last), its frames the plan's."""
    if killed is None or fault.kind == "master-kill":
        return _outcome(fault, record, harness, killed, out)
    if fault.frame <= killed.frames:
        return _outcome(fault, killed, harness, killed, out)
    offset = killed.frames
    outcome = _outcome(dataclasses.replace(fault, frame=fault.frame - offset), record,
                       harness, killed, out)
    shifted = {key: outcome[key] + offset for key in ("detected_frame", "healed_frame")
               if outcome[key] is not None}
    return {**outcome, **shifted, "fault": str(fault), "frame": fault.frame}


def _outcome(fault: Fault, record: RunRecord, harness,
             killed: RunRecord | None, out: Path) -> dict:
    """When the master noticed `fault`, whom it named, and when the node was whole again;
    for the attacks, what was refused (`detection`) and what became of the run (`outcome`);
    for a bitflip, whether the forensics named its particle, field and bit (`localisation`)."""
    detected, named, healed_at, detection, outcome = None, [], None, {}, ""
    localisation = None
    node_rejected = sum(record.node_rejected.values())
    if fault.kind in ("bitflip", "seed", "stale", "jitter", "shove"):
        hit = next((d for d in record.divergences
                    if d.frame >= fault.frame and fault.node in d.nodes), None)
        if hit:
            detected, named = hit.frame, list(hit.nodes)
            healed_at = _resynced(record, fault.node, hit.frame)
        if fault.kind == "bitflip":
            localisation = localised(fault, hit, _live_at(record, fault.frame), out)
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
    if localisation is not None:
        result["localisation"] = localisation
    return result


def localised(fault: Fault, divergence: Divergence | None, live: int | None,
              out: Path) -> dict:
    """What the bitflip `fault` flipped (from the live count at its frame) against what the
    forensic report of its divergence names: `exact` when it names that one field of that
    one particle, and the two values differ in that one bit."""
    expected = None
    if live:
        target = bitflip_target(live)
        field, bit = field_bit(PARTICLE_DTYPE, target.word, target.bit)
        expected = {"stream": "particles", "record": target.particle, "field": field.name,
                    "bit": bit}
    reported, file = [], None
    if divergence is not None and divergence.forensics:
        file = divergence.forensics["file"]
        reported = named_fields(json.loads((out / file).read_text()), fault.node)
    return {"expected": expected, "reported": reported[:8], "report": file,
            "exact": expected is not None and reported == [expected]}


def named_fields(report: dict, node: str | None) -> list[dict]:
    """Every differing field a forensic report names between `node` and another node: its
    stream, record, field and, when the values differ in one bit, that bit (else None)."""
    found = []
    for one in (report, *report.get("other_odd_nodes", ())):
        if node not in (one["odd_node"], one["reference_node"]):
            continue
        for stream in one.get("streams", ()):
            for record in stream["records"]:
                for field in record["fields"]:
                    xor = int(field["xor"], 16)
                    found.append({"stream": stream["stream"], "record": record["index"],
                                  "field": field["field"],
                                  "bit": xor.bit_length() - 1 if xor.bit_count() == 1
                                  else None})
    return found


def _live_at(record: RunRecord, frame: int) -> int | None:
    """The agreed live count after `frame` (None if the record's series skipped it)."""
    series = record.live_particles
    return dict(zip(series.frames(), series, strict=True)).get(frame)


def _resynced(record: RunRecord, node: str, frame: int) -> int | None:
    return next((r.frame for r in record.resyncs
                 if r.node == node and r.frame >= frame and r.ok), None)
