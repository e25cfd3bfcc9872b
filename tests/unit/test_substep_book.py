"""The adaptive tracers' substeps in a run: carried on the wire in each node's report, kept
by the master from the agreed node's, and shown in report.json and the closing table."""

import pytest
from scenes import SMOKE, scene_dict

from cavesim.core.errors import ProtocolError
from cavesim.core.frame_cost import PHASES
from cavesim.core.scene import parse_scene
from cavesim.core.wire import ReportMessage
from cavesim.core.wire.payloads.from_nodes import read_report, write_report
from cavesim.tools.reports.run_tables import substep_rows
from nodes.master.run_record import RunRecord
from nodes.master.substep_book import SubstepBook

COST = (0,) * len(PHASES)


def scene(tracer_method: str | None = "rk45"):
    data = scene_dict(integrator="rk4")
    data["particle_class"] = [*data["particle_class"], dict(SMOKE)]
    if tracer_method is not None:
        data["simulation"]["tracer_method"] = tracer_method
    return parse_scene(data, name="smoky")


def test_the_book_sums_each_frame_and_keeps_the_most():
    book = SubstepBook(scene())
    for k, counts in enumerate([(10, 10, 0, 1), (10, 17, 4, 3), (), (12, 30, 9, 5)], start=1):
        book.add(k, counts)
    summary = book.summary()
    assert (summary["tracer_frames"], summary["taken"], summary["retaken"]) == (32, 57, 13)
    assert summary["per_tracer_frame"] == round(57 / 32, 3)
    assert (summary["most"], summary["most_frame"]) == (5, 4)
    assert summary["frames_uncounted"] == 1
    assert summary["per_frame"] == [[10, 10, 0], [10, 17, 4], [12, 30, 9]]
    [(label, text)] = substep_rows(summary)
    assert label == "tracer substeps"
    assert text == "1.781 a tracer a frame, 13 retaken, at most 5 (frame 4) (1 frames not counted)"


def test_a_scene_whose_tracers_take_no_substeps_keeps_none():
    book = SubstepBook(scene(tracer_method=None))
    book.add(1, (3, 3, 0, 1))
    assert book.summary() == {} and substep_rows({}) == []
    assert RunRecord(("front",), tracer_substeps=book).summary()["tracer_substeps"] == {}


@pytest.mark.parametrize("substeps", [(), (5, 7, 2, 3), (2**32 - 1,) * 4])
def test_a_report_carries_its_tracer_substeps(substeps):
    report = ReportMessage(3, "front", "ab" * 16, 10, 2, COST, domain_exits=(1, 2),
                           tracer_substeps=substeps)
    assert read_report(3, write_report(report)) == report


def test_a_report_with_other_substep_counts_or_cut_short_is_refused():
    with pytest.raises(ValueError, match="4 counts or none, got 3"):
        write_report(ReportMessage(3, "front", "ab" * 16, 10, 2, COST,
                                   tracer_substeps=(1, 2, 3)))
    data = write_report(ReportMessage(3, "front", "ab" * 16, 10, 2, COST,
                                      tracer_substeps=(1, 2, 3, 4)))
    with pytest.raises(ProtocolError, match="tracer substeps of 4 counts in 15 bytes"):
        read_report(3, data[:-1])
    with pytest.raises(ProtocolError, match="ends before its count of tracer substeps"):
        read_report(3, data[:-17])
    bad = bytearray(data)
    bad[-17] = 2  # a count of 2: neither none nor the four
    with pytest.raises(ProtocolError, match="expected 0 or 4 counts"):
        read_report(3, bytes(bad))
