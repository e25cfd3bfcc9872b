"""Desync forensics in this process: the master's whole loop over walls in memory that hold
real records (tests/support/memory_walls.py), a flipped bit found top-down down to its record, field
and bit, and since when; and the record differences themselves."""

import json
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from memory_walls import MemoryLink

from cavesim.core.record_diff import differences, field_bit
from cavesim.core.records import PARTICLE_DTYPE
from cavesim.core.wire import BlockQuery
from cavesim.tools.reports.run_tables import forensic_lines
from nodes.check.findings import EVIDENCE, check_passed, check_report
from nodes.faults import KINDS, BitFlip, Fault, bitflip_target
from nodes.master.process import MasterConfig, run_master
from nodes.master.run_record import LiveCounts

MINIMAL = Path(__file__).parents[2] / "config" / "scenes" / "minimal.toml"
WALLS = ("front", "left", "right")
PARTICLES = 5000  # four blocks of the checksum's tree


def run(tmp_path, flips: dict[int, BitFlip], frames: int = 20, check_every: int = 1,
        particles: int = PARTICLES):
    link = MemoryLink(WALLS, particles=particles)
    link.walls["left"].flip_bits.update(flips)
    record = run_master(MasterConfig(WALLS, MINIMAL, frames, "forensics",
                                     check_every=check_every, forensics=tmp_path), link)
    assert record.final.agree
    return record, link


def report_of(tmp_path, frame: int) -> dict:
    return json.loads((tmp_path / "divergences" / f"frame_{frame}.json").read_text())


@pytest.mark.parametrize(("word", "bit", "field", "field_bit_"),
                         [(4, 7, "vel.y", 7), (6, 20, "age", 20), (7, 20, "age", 52),
                          (9, 31, "pos_low.z", 7)])
def test_a_flipped_bit_is_named_by_record_field_and_bit(tmp_path, word, bit, field, field_bit_):
    record, link = run(tmp_path, {12: BitFlip(1234, word, bit)})
    (divergence,) = record.divergences
    report = report_of(tmp_path, 12)
    assert (report["frame"], report["odd_node"], report["reference_node"]) == \
        (12, "left", "front")
    (stream,) = report["streams"]
    assert stream["stream"] == "particles" and stream["differing_records"] == 1
    (found,) = stream["records"]
    (difference,) = found["fields"]
    assert found["index"] == 1234 and difference["field"] == field
    xor = int(difference["odd"]["bits"], 16) ^ int(difference["reference"]["bits"], 16)
    assert xor == 1 << field_bit_ == int(difference["xor"], 16)
    assert (found["first_differing_frame"], found["first_differing_frame_exact"]) == (12, True)
    assert divergence.forensics["file"] == "divergences/frame_12.json"
    assert divergence.forensics["summary"] == report["summary"]
    assert report["summary"].startswith(f"frame 12: left differs from front in particle 1234 "
                                        f"{field}: ")
    assert report["summary"].endswith("since frame 12")


def test_only_the_differing_branch_of_the_tree_and_its_records_are_fetched(tmp_path):
    run(tmp_path, {5: BitFlip(4000, 0, 3)}, frames=6)
    report = report_of(tmp_path, 5)
    (stream,) = report["streams"]
    assert stream["differing_blocks"] == 1 and stream["differing_invocations"] == 1
    assert stream["records_compared"] <= 256  # one invocation's words: a word per record
    # per node: the top (one item), 5 blocks (4 of particles, 1 of emitters), one block's
    # 64 sums, at most 256 records, 5 frames of history of the 5 blocks
    assert report["bytes_fetched"] <= 2 * (16 + 5 * 16 + 64 * 8 + 256 * 40 + 5 * 5 * 16)
    assert report["history"] == {"frames": [1, 5], "blocks": [0, 5]}


def test_between_checks_the_history_tells_since_when_the_blocks_differ(tmp_path):
    record, link = run(tmp_path, {12: BitFlip(1234, 3, 22)}, frames=20, check_every=5)
    (divergence,) = record.divergences
    assert divergence.frame == 15
    (stream,) = report_of(tmp_path, 15)["streams"]
    (found,) = stream["records"]
    assert [f["field"] for f in found["fields"]] == ["pos.x", "vel.x"]  # vel.x moved pos.x
    assert (found["first_differing_frame"], found["first_differing_frame_exact"]) == (12, True)
    history = [q for q in link.block_questions if q.query is BlockQuery.HISTORY]
    assert len(history) == 2 and history[0].frame == 15


def test_a_node_that_does_not_answer_leaves_a_report_that_says_so(tmp_path):
    link = MemoryLink(WALLS)  # digests only: the walls hold no records to ask about
    link.walls["left"].flip_at.add(3)
    record = run_master(MasterConfig(WALLS, MINIMAL, 5, "forensics", forensics=tmp_path), link)
    assert record.final.agree and len(record.resyncs) == 1  # still healed
    report = report_of(tmp_path, 3)
    assert "did not answer" in report["error"]
    assert report["summary"].startswith("frame 3: left differs from front; forensics stopped")


def test_the_injected_bitflip_is_a_function_of_the_live_count():
    assert bitflip_target(5001) == BitFlip(2500, 5, 20)  # word 25005: vel.z of record 2500
    assert field_bit(PARTICLE_DTYPE, 5, 20)[0].name == "vel.z"
    assert bitflip_target(4) == BitFlip(2, 0, 20)
    with pytest.raises(ValueError, match="needs a live particle"):
        bitflip_target(0)


def test_differences_give_values_bits_and_ulp_distances():
    a = np.zeros(2, PARTICLE_DTYPE)
    a["pos"][1, 1] = 1.25
    a["class_id"][0] = 3
    b = a.copy()
    b["pos"][1, 1] = np.nextafter(np.float32(1.25), np.float32(2))
    b["age"][1] = -0.0
    b["class_id"][0] = 7
    found = {(d.record, d.field.name): d.to_json()
             for d in differences(PARTICLE_DTYPE, np.array([10, 11]), a.tobytes(), b.tobytes())}
    assert set(found) == {(10, "class_id"), (11, "pos.y"), (11, "age")}
    pos = found[(11, "pos.y")]
    assert (pos["odd"], pos["reference"]) == ({"value": 1.25, "bits": "0x3fa00000"},
                                              {"value": 1.2500001, "bits": "0x3fa00001"})
    assert (pos["distance"], pos["xor"]) == (1, "0x00000001")
    assert found[(11, "age")]["distance"] == 0  # +0 and -0 are neighbours at distance 0
    assert found[(11, "age")]["xor"] == "0x8000000000000000"
    assert (found[(10, "class_id")]["distance"], found[(10, "class_id")]["distance_unit"]) == \
        (4, "integer difference")


def test_the_check_knows_where_each_fault_kind_leaves_its_evidence():
    assert set(EVIDENCE) == set(KINDS)


def checked(tmp_path, record, fault) -> dict:
    harness = SimpleNamespace(rogue=None, sent=dict)  # a harness that sent nothing
    return check_report(WALLS, (fault,), record, harness, None, tmp_path)


@pytest.mark.parametrize(("path", "wrong"), [
    (("streams", 0, "records", 0, "index"), 2501),  # another particle
    (("streams", 0, "records", 0, "fields", 0, "field"), "pos.y"),  # another field
    (("streams", 0, "records", 0, "fields", 0, "xor"), "0x00080000"),  # another bit
    (("streams", 0, "stream"), "emitters"),  # another stream
])
def test_the_check_asserts_the_localisation_and_fails_on_a_wrong_one(tmp_path, path, wrong):
    target = bitflip_target(PARTICLES)  # as a node flips: pos.x of particle 2500, bit 20
    record, _ = run(tmp_path, {12: target})
    fault = Fault("bitflip", 12, "left")
    report = checked(tmp_path, record, fault)
    (outcome,) = report["faults"]
    assert outcome["localisation"] == {
        "expected": {"stream": "particles", "record": 2500, "field": "pos.x", "bit": 20},
        "reported": [{"stream": "particles", "record": 2500, "field": "pos.x", "bit": 20}],
        "report": "divergences/frame_12.json", "exact": True}
    assert report["all_localised"] and check_passed(report, injected=True)
    file = tmp_path / "divergences" / "frame_12.json"
    forensics = json.loads(file.read_text())
    *inside, last = path
    place = forensics
    for key in inside:
        place = place[key]
    place[last] = wrong
    file.write_text(json.dumps(forensics))
    report = checked(tmp_path, record, fault)
    assert not report["faults"][0]["localisation"]["exact"]
    assert not report["all_localised"] and not check_passed(report, injected=True)


def test_a_bitflip_the_forensics_could_not_explain_fails_the_check(tmp_path):
    record, _ = run(tmp_path, {12: bitflip_target(PARTICLES)})
    (tmp_path / "divergences" / "frame_12.json").write_text(json.dumps(
        {"frame": 12, "odd_node": "left", "reference_node": "front", "error": "no answer"}))
    report = checked(tmp_path, record, Fault("bitflip", 12, "left"))
    assert report["faults"][0]["localisation"]["reported"] == []
    assert not check_passed(report, injected=True)


def test_run_prints_what_differed_at_each_divergence(tmp_path):
    record, _ = run(tmp_path, {5: BitFlip(10, 1, 2), 9: BitFlip(20, 2, 3)}, frames=10)
    lines = forensic_lines(record.summary(), shown=1)
    assert lines[0].startswith("frame 5: left differs from front in particle 10 pos.y: ")
    assert lines[0].endswith("(divergences/frame_5.json)")
    assert lines[1] == "... and 1 more in divergences/"


def test_a_bitflip_is_localised_by_its_divergences_live_count_in_a_long_run(tmp_path):
    """A long run's series of live counts keeps only some frames; the bitflip's target comes
    from the live count its divergence recorded."""
    record, _ = run(tmp_path, {12: bitflip_target(PARTICLES)})
    record.live_particles = LiveCounts()  # as if the series had skipped frame 12
    report = checked(tmp_path, record, Fault("bitflip", 12, "left"))
    assert report["faults"][0]["localisation"]["exact"] and report["all_localised"]
