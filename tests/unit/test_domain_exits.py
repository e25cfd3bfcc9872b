"""The particles that leave the field's box: summed per frame without losing any count,
recorded per class by the master from the agreed node's report, warned about once, and
carried on the wire."""

import logging

import pytest
from scenes import scene_dict

from cavesim.core.bounded import BinnedSums
from cavesim.core.errors import ProtocolError
from cavesim.core.frame_cost import PHASES
from cavesim.core.limits import MAX_PARTICLE_CLASSES
from cavesim.core.scene import load_scene, parse_scene
from cavesim.core.wire import ReportMessage
from cavesim.core.wire.payloads.from_nodes import read_report, write_report
from nodes.master.exit_book import DomainExitBook
from nodes.master.run_record import RunRecord

BROWNOUT = "config/scenes/brownout.toml"
COST = (0,) * len(PHASES)


def test_binned_sums_keep_every_count_as_bins_merge():
    sums = BinnedSums(2, capacity=4)
    for k in range(1, 12):
        sums.add((k, 1))
    assert sums.stride == 4 and sums.bins() == [[10, 4], [26, 4], [30, 3]]
    assert sums.totals == [66, 11] and sums.count == 11
    with pytest.raises(ValueError, match="expected 2 counts, got 3"):
        sums.add((1, 2, 3))


def test_the_book_counts_per_class_and_frame_and_warns_once(caplog):
    book = DomainExitBook(parse_scene(scene_dict(), name="grid"))
    assert book.classes == ("sand", "dust")
    with caplog.at_level(logging.WARNING, logger="cavesim.master"):
        for k, counts in enumerate([(0, 0), (0, 3), (2, 1), (0, 0)], start=1):
            book.add(k, counts)
    [warning] = caplog.messages
    assert warning.startswith("frame 2: particles left the field's box [-4.0, -4.0, 0.0] .. "
                              "[4.0, 4.0, 4.0] (3 dust); beyond it the flow is the nearest "
                              "boundary node's (out_of_domain)")
    summary = book.summary()
    assert summary["total"] == {"sand": 2, "dust": 4}
    assert summary["first_frame"] == {"dust": 2, "sand": 3}
    assert summary["per_frame"] == [[0, 0], [0, 3], [2, 1], [0, 0]]
    assert summary["per_frame_stride"] == 1 and summary["frames_uncounted"] == 0


def test_a_report_that_counts_nothing_or_the_wrong_classes_is_counted_as_uncounted():
    book = DomainExitBook(parse_scene(scene_dict(), name="grid"))
    book.add(1, ())
    book.add(2, (1, 2, 3))
    book.add(3, (1, 0))
    assert book.summary()["frames_uncounted"] == 2
    assert book.summary()["per_frame"] == [[0, 0], [0, 0], [1, 0]]


def test_a_scene_without_a_grid_records_no_exits():
    book = DomainExitBook(load_scene(BROWNOUT))
    book.add(1, (5,))
    assert book.summary() == {}
    record = RunRecord(("front",), domain_exits=book)
    assert record.summary()["domain_exits"] == {}


@pytest.mark.parametrize("exits", [(), (0, 7), tuple(range(MAX_PARTICLE_CLASSES))])
def test_a_report_carries_its_domain_exits(exits):
    report = ReportMessage(3, "front", "ab" * 16, 10, 2, COST, domain_exits=exits)
    assert read_report(3, write_report(report)) == report


def test_a_report_with_exits_beyond_the_class_limit_or_cut_short_is_refused():
    with pytest.raises(ValueError, match=f"at most {MAX_PARTICLE_CLASSES} classes, got 65"):
        write_report(ReportMessage(3, "front", "ab" * 16, 10, 2, COST,
                                   domain_exits=(1,) * 65))
    data = write_report(ReportMessage(3, "front", "ab" * 16, 10, 2, COST, domain_exits=(1, 2)))
    # the exits end with the report's count of tracer substeps (none here): one byte more
    with pytest.raises(ProtocolError, match="domain exits of 2 classes in 7 bytes"):
        read_report(3, data[:-2])
    with pytest.raises(ProtocolError, match="ends before its count of domain exits"):
        read_report(3, data[:-10])
