"""The new particles a full capacity drops: summed per frame without losing any count,
recorded by the master from the agreed node's report, said once (the master's log and
`cavesim run`'s terminal), shown in the run's table and carried on the wire."""

import logging

import pytest
from rich.console import Console

from cavesim.core.bounded import BinnedSums
from cavesim.core.errors import ProtocolError
from cavesim.core.frame_cost import PHASES
from cavesim.core.wire import ReportMessage
from cavesim.core.wire.payloads.from_nodes import read_report, write_report
from cavesim.tools.reports.run_tables import drop_rows
from nodes.commands.run import drop_notice
from nodes.master.drop_book import CapacityDropBook
from nodes.master.run_record import RunRecord

COST = (0,) * len(PHASES)
DT = 1 / 60
LINE = ("capacity full: 1,234 new particles dropped at frame 3 (the scene holds 300,000); "
        "report.json counts every frame's (capacity_drops.dropped_per_second)")


def test_binned_sums_give_rates_per_second_of_the_frames_each_bin_holds():
    sums = BinnedSums(1, capacity=2)
    for n in (6, 0, 3, 3, 12):  # bins of 4 frames after the merges, the last of 1
        sums.add((n,))
    assert sums.stride == 4 and sums.bins() == [[12], [12]]
    assert sums.rates(0.5) == [[6.0], [24.0]]


def test_the_book_counts_each_frame_and_says_it_once(caplog):
    book = CapacityDropBook(300_000, DT)
    with caplog.at_level(logging.WARNING, logger="cavesim.master"):
        for k, dropped in enumerate([0, 0, 1234, 50, 0], start=1):
            book.add(k, dropped)
    assert caplog.messages == [LINE] and book.notice == LINE
    summary = book.summary()
    assert summary == {"capacity": 300_000, "total": 1284, "first_frame": 3,
                       "dropped_at_first_frame": 1234,
                       "dropped_per_second": [0.0, 0.0, 74040.0, 3000.0, 0.0],
                       "bin_frames": 1, "bin_seconds": round(DT, 6)}
    record = RunRecord(("front",), capacity_drops=book)
    assert record.summary()["capacity_drops"] == summary


def test_a_run_that_drops_nothing_says_nothing_and_its_table_says_none():
    book = CapacityDropBook(4000, DT)
    book.add(1, 0)
    assert book.notice is None
    summary = book.summary()
    assert summary["total"] == 0 and summary["first_frame"] is None
    assert summary["dropped_per_second"] == []  # no per-frame zeros in the report
    assert drop_rows(summary) == [("dropped at capacity", "none (capacity 4,000)")]
    assert drop_rows({}) == []  # a report from before drops were counted


def test_the_table_names_the_total_and_the_first_frame():
    book = CapacityDropBook(300_000, DT)
    for k, dropped in enumerate([0, 0, 1234, 50], start=1):
        book.add(k, dropped)
    assert drop_rows(book.summary()) == [("dropped at capacity",
                                          "1,284 from frame 3 (capacity 300,000)")]


def test_cavesim_runs_terminal_gets_the_line_once():
    console = Console(record=True, width=200)
    tell = drop_notice(console)
    record = RunRecord(("front",), capacity_drops=CapacityDropBook(300_000, DT))
    for k, dropped in enumerate([0, 0, 1234, 50, 7], start=1):
        record.capacity_drops.add(k, dropped)
        tell(record)
    assert console.export_text().splitlines() == [LINE]


@pytest.mark.parametrize("dropped", [0, 1, 2**32 - 1])
def test_a_report_carries_its_dropped_count(dropped):
    report = ReportMessage(3, "front", "ab" * 16, 10, 2, COST, dropped=dropped)
    assert read_report(3, write_report(report)) == report


def test_a_drop_out_of_range_or_without_a_full_pool_is_refused():
    with pytest.raises(ValueError, match=r"dropped count must be in \[0, 2\*\*32\), got -1"):
        write_report(ReportMessage(3, "front", "ab" * 16, 10, 2, COST, dropped=-1))
    data = write_report(ReportMessage(3, "front", "ab" * 16, 0, 2, COST, dropped=5))
    with pytest.raises(ProtocolError, match="drops 5 particles at the capacity with none live"):
        read_report(3, data)
