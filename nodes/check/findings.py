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
from cavesim.core.wire.credentials import WALL
from nodes.check import forgery_findings
from nodes.check.evidence import (
    Evidence,
    diverged_at,
    first_divergence,
    live_at,
    none_lost_since,
    refused_meanwhile,
    resynced_at,
)
from nodes.check.rogue import FORGED_HEAD, TAKEN_HEAD
from nodes.check.straggler import straggler_findings
from nodes.faults import (
    FLOOD_MESSAGES,
    FLOOD_QUERIES,
    SETTLE,
    Fault,
    bitflip_target,
    divergence_frames,
)
from nodes.master.budgets import LAG
from nodes.master.run_record import Divergence, Loss, RunRecord


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
        "divergences": record.divergences.total + (killed.divergences.total if killed else 0),
        "rogue_messages_sent": harness.sent(),
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
    """`fault`'s entry in check.json, from the evidence its kind leaves (`EVIDENCE`)."""
    found = EVIDENCE[fault.kind](fault, record, harness, killed, out)
    result = {"fault": str(fault), "kind": fault.kind, "frame": fault.frame,
              "node": fault.node, "detected_frame": found.detected, "named": found.named,
              "healed_frame": found.healed_at,
              "healed": found.healed_at is not None and record.agreed_at_the_end()}
    if found.detection:
        result |= {"detection": found.detection, "outcome": found.outcome}
    if found.localisation is not None:
        result["localisation"] = found.localisation
    return result


def _divergence(fault: Fault, record: RunRecord, harness, killed, out: Path) -> Evidence:
    """A node that computes something else: the first divergence naming it, healed by its
    resync; a bitflip must also be localised."""
    hit = first_divergence(record, fault)
    localisation = localised(fault, hit, live_at(record, fault, hit), out) \
        if fault.kind == "bitflip" else None
    if hit is None:
        return Evidence(localisation=localisation)
    return Evidence(hit.frame, list(hit.nodes), resynced_at(record, fault.node, hit.frame),
                    localisation=localisation)


def _stall(fault: Fault, record: RunRecord, harness, killed, out: Path) -> Evidence:
    """A node that misses the barrier: the stall of that frame naming it, healed once the
    run went past the frame with the node in (one late frame is within its lag budget)."""
    hit = next((s for s in record.stalls
                if s.frame == fault.frame and fault.node in s.nodes), None)
    if hit is None:
        return Evidence()
    given_up = any(loss == Loss(fault.frame, fault.node, LAG) for loss in record.losses)
    return Evidence(hit.frame, sorted(hit.nodes),
                    fault.frame if record.frames > fault.frame and not given_up else None)


def _loss(fault: Fault, record: RunRecord, harness, killed, out: Path) -> Evidence:
    """A killed node: its loss, healed when it joined again (or else was resynced)."""
    hit = next((loss for loss in record.losses
                if loss.node == fault.node and loss.frame >= fault.frame - 1), None)
    if hit is None:
        return Evidence()
    rejoined = next((j.frame for j in record.joins
                     if j.node == fault.node and j.frame >= hit.frame),
                    resynced_at(record, fault.node, hit.frame))
    return Evidence(hit.frame, [fault.node], rejoined)


def _attack(fault: Fault, record: RunRecord, harness, killed, out: Path) -> Evidence:
    """Junk or replayed messages: detected and healed when the nodes refused some."""
    refused = sum(record.node_rejected.values())
    at = fault.frame if refused else None
    return Evidence(at, healed_at=at, detection={
        "sent": harness.sent(), "refused_by_nodes": refused,
        "refused_by_master": dict(record.master_rejected)},
        outcome=f"{record.frames} frames ran to the end with {record.divergences.total} "
                f"divergence(s): no replayed or forged message was stepped or obeyed")


def _flood(fault: Fault, record: RunRecord, harness, killed, out: Path) -> Evidence:
    """A flood: detected when the nodes counted every junk message, healed when no node
    was lost."""
    refused = sum(record.node_rejected.values())
    return Evidence(
        fault.frame if refused >= FLOOD_MESSAGES else None,
        healed_at=fault.frame if none_lost_since(record, fault.frame) else None,
        detection={**harness.measured[str(fault)], "refused_by_nodes": refused},
        outcome=f"{FLOOD_MESSAGES:,} junk messages and {FLOOD_QUERIES:,} unsigned state "
                f"queries in {harness.measured[str(fault)].get('seconds')} s: counted, logged "
                f"at a bounded rate, no node lost")


def _query_replay(fault: Fault, record: RunRecord, harness, killed, out: Path) -> Evidence:
    """The walls' own queries replayed while a node resyncs: detected when the nodes
    refused at least as many queries as were replayed, healed when the resync they were
    replayed against loaded the state."""
    sent = harness.sent()
    replayed = sent.get("replayed-query", 0) + sent.get("earlier-run-query", 0)
    refused = sum(record.node_rejected.values())
    second = divergence_frames(fault)[1]
    resync = next((r for r in record.resyncs if r.node == fault.node and r.frame >= second),
                  None)
    detected = second if replayed and refused >= replayed else None
    detection = {"replayed_queries": sent.get("replayed-query", 0),
                 "earlier_run_queries": sent.get("earlier-run-query", 0),
                 "refused_by_nodes": refused,
                 "resync_seconds": round(resync.seconds, 4) if resync else None}
    if resync is None or not resync.ok:
        return Evidence(detected, detection=detection, outcome=f"{fault.node} was not healed")
    return Evidence(detected, [fault.node], resync.frame, detection,
                    f"{fault.node} resynced in {resync.seconds:.3f} s while "
                    f"{replayed:,} replayed queries were refused")


def _tracking_replay(fault: Fault, record: RunRecord, harness, killed, out: Path
                     ) -> Evidence:
    """An earlier run's tracking, unsigned tracking, a replayed and a stale one: detected
    when the master refused each by its reason, healed when no frame carried the replayed
    pose (and one did carry the one fresh message's, so that a pose is seen at all)."""
    sent, refused = harness.sent(), record.master_rejected
    expected = {"wrong-run": "earlier-run-tracking", "unsigned": "unsigned-tracking",
                "replayed-tracking": "replayed-tracking", "stale-tracking": "stale-tracking"}
    caught = all(sent.get(what, 0) and refused.get(reason, 0) >= sent[what]
                 for reason, what in expected.items())
    member = harness.credentials.issue(WALL, record.walls[0])
    forged = harness.rogue.frames_with_head(FORGED_HEAD, member, record.run_id)
    taken = harness.rogue.frames_with_head(TAKEN_HEAD, member, record.run_id)
    return Evidence(
        fault.frame if caught else None,
        healed_at=fault.frame if forged == 0 and taken else None,
        detection={"sent": {what: sent.get(what, 0) for what in (*expected.values(),
                                                                  "fresh-tracking")},
                   "refused_by_master": {r: refused.get(r, 0) for r in expected},
                   "frames_with_the_replayed_pose": forged,
                   "frames_with_the_fresh_pose": taken},
        outcome=f"no frame carried a replayed pose; the one fresh message's pose reached "
                f"{taken} frame(s)")


def _second_master(fault: Fault, record: RunRecord, harness, killed, out: Path) -> Evidence:
    """A second master with the same keys: detected when it refused to start with one line
    and the running master counted it (and the one that missed it, by its token); healed
    when no wall left the run or diverged while the other run's frames came."""
    second = harness.second_master
    counted = record.master_rejected.get("other-master", 0)
    refused = second.get("refused")
    window = range(fault.frame, fault.frame + SETTLE)
    stayed = none_lost_since(record, fault.frame) and not any(
        diverged_at(record, k) for k in window)
    return Evidence(
        fault.frame if refused and "\n" not in refused and counted >= 2 else None,
        healed_at=fault.frame if stayed else None,
        detection={"second_master": second, "counted_by_the_master": counted,
                   "frames_signed_for_another_run": harness.sent().get("second-master-frame",
                                                                       0),
                   "refused_by_nodes": sum(record.node_rejected.values())},
        outcome=f"every wall stayed in run {record.run_id:016x}, in agreement"
        if stayed else "a wall left the run or diverged")


def _oversize(fault: Fault, record: RunRecord, harness, killed, out: Path) -> Evidence:
    """Messages larger than the transport takes: detected when none reached a node (from
    just before them to the measurement after, each counted the junk under the limit, and
    no more), healed when no node was lost."""
    sent, measured = harness.sent(), harness.measured[str(fault)]
    under = sent.get("junk-under-the-limit", 0)
    oversize = sent.get("oversize-message", 0) + sent.get("oversize-query", 0)
    by_node = refused_meanwhile(measured)
    caught = oversize and by_node and all(under <= n < under + oversize
                                          for n in by_node.values())
    return Evidence(
        fault.frame if caught else None,
        healed_at=fault.frame if none_lost_since(record, fault.frame) else None,
        detection={**measured, "oversize_sent": oversize,
                   "junk_under_the_limit_sent": under, "refused_by_nodes": by_node},
        outcome=f"{oversize} messages and queries over the transport's limit dropped before "
                f"any was buffered; each node counted only the {under} under it")


def _straggler(fault: Fault, record: RunRecord, harness, killed, out: Path) -> Evidence:
    """A node slower than --max-lag every frame: named, given up within the lag budget,
    the others' rate back, its restarted node in again (`straggler.py`)."""
    named, healed, detection, outcome = straggler_findings(
        fault, record, harness.frame_times.get(str(fault), {}))
    return Evidence(named, [fault.node] if named else [], healed, detection, outcome)


def _master_kill(fault: Fault, record: RunRecord, harness, killed: RunRecord,
                 out: Path) -> Evidence:
    """A killed master: detected when every node noticed, healed when a new master ran
    with all of them."""
    rejoined = list(record.final.members) if record.final else []
    everyone_noticed = len(harness.noticed) == len(record.walls)
    return Evidence(
        fault.frame if everyone_noticed else None,
        list(harness.noticed) if everyone_noticed else [],
        fault.frame if set(rejoined) == set(record.walls) and record.frames else None,
        {"killed_run": f"{killed.run_id:016x}", "frames_before": killed.frames,
         "nodes_that_noticed": harness.noticed, "new_run": f"{record.run_id:016x}",
         "nodes_in_the_new_run": rejoined},
        f"a new master took the {len(rejoined)} nodes over from the scene's start and ran "
        f"{record.frames} more frames")


EVIDENCE = {  # fault kind -> where the run's record shows it
    "bitflip": _divergence, "seed": _divergence, "stale": _divergence,
    "jitter": _divergence, "shove": _divergence, "inflate": _divergence,
    "drop": _stall, "slow": _stall,
    "straggler": _straggler,
    "kill": _loss,
    "rogue": _attack, "replay-attack": _attack,
    "snapshot-forgery": forgery_findings.state_forgery,
    "flood": _flood,
    "report-forgery": forgery_findings.report_forgery,
    "query-replay": _query_replay,
    "tracking-replay": _tracking_replay,
    "second-master": _second_master,
    "snapshot-collision": forgery_findings.collision,
    "colliding-source": forgery_findings.colliding_source,
    "oversize": _oversize,
    "control-forgery": forgery_findings.control_forgery,
    "count-forgery": forgery_findings.count_forgery,
    "master-kill": _master_kill,
}


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


