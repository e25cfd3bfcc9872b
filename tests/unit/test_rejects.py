"""Rejected messages: exact counts, a log whose size does not follow the flood, thread-safe."""

import logging
import threading

import pytest

from cavesim.core.errors import ProtocolError
from cavesim.core.wire.rejects import RejectCounter

KEY = "cavesim/test/frame"


class FakeClock:
    def __init__(self) -> None:
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


@pytest.fixture
def lines(caplog):
    caplog.set_level(logging.WARNING, logger="cavesim.wire")
    return lambda: [r.getMessage() for r in caplog.records if r.name == "cavesim.wire"]


def bad(reason: str = "bad-signature", detail: str = "the tag does not match"):
    return ProtocolError(reason, detail)


def test_a_flood_logs_a_bounded_number_of_lines_and_counts_exactly(lines):
    clock = FakeClock()
    rejects = RejectCounter("node front", interval=10.0, clock=clock)
    for i in range(100_000):
        clock.now += 1e-4  # 100,000 rejects in 10 s: crosses the interval once
        rejects.reject(bad("bad-signature" if i % 4 else "truncated"), KEY)
    assert rejects.counts == {"bad-signature": 75_000, "truncated": 25_000}
    assert rejects.total == 100_000
    assert len(lines()) <= 4  # first of each reason, at most one more line per reason
    rejects.flush()
    assert "node front rejected 100,000 messages in all: bad-signature 75,000, truncated " \
           "25,000" == lines()[-1]


def test_a_reason_seen_once_logs_once(lines):
    rejects = RejectCounter("master", clock=FakeClock())
    rejects.reject(bad("truncated", "13 bytes"), KEY)
    assert lines() == [f"master rejected a message on {KEY}: truncated: 13 bytes"]
    rejects.flush()
    assert lines()[1:] == ["master rejected 1 message in all: truncated 1"]


def test_the_periodic_line_comes_after_the_interval(lines):
    clock = FakeClock()
    rejects = RejectCounter("node front", interval=10.0, clock=clock)
    rejects.reject(bad(), KEY)
    for _ in range(48_211):
        clock.now += 9.0 / 48_211  # within the interval: counted, not logged
        rejects.reject(bad(), "cavesim/test/control")
    assert len(lines()) == 1
    clock.now = 110.0  # exactly the interval after the first line
    rejects.reject(bad(detail="the last one"), "cavesim/test/frame")
    assert lines()[1] == ("node front rejected 48,212 more bad-signature messages in the "
                          "last 10 s (48,213 in all); the last on cavesim/test/frame: "
                          "bad-signature: the last one")
    clock.now += 5.0
    rejects.reject(bad(), KEY)  # the next line is an interval away again
    assert len(lines()) == 2


def test_flush_logs_what_was_not_logged_yet_then_nothing_twice(lines):
    clock = FakeClock()
    rejects = RejectCounter("node left", clock=clock)
    rejects.flush()
    assert lines() == []  # nothing rejected, nothing to say
    for _ in range(3):
        rejects.reject(bad("bad-count", "7 chunks"), KEY)
    clock.now += 2.0
    rejects.flush()
    assert lines()[1:] == [
        f"node left rejected 2 more bad-count messages in the last 2 s (3 in all); the last "
        f"on {KEY}: bad-count: 7 chunks",
        "node left rejected 3 messages in all: bad-count 3"]
    rejects.flush()
    assert lines()[3:] == ["node left rejected 3 messages in all: bad-count 3"]


def test_counts_are_exact_from_many_threads(lines):
    rejects = RejectCounter("master")
    per_thread, threads = 20_000, 8
    reasons = ("bad-signature", "truncated", "unexpected")

    def flood(n: int) -> None:
        for i in range(per_thread):
            rejects.reject(bad(reasons[(i + n) % 3]), KEY)
            if i % 1000 == 0:
                assert rejects.total <= per_thread * threads and sum(rejects.counts.values())

    workers = [threading.Thread(target=flood, args=(n,)) for n in range(threads)]
    for worker in workers:
        worker.start()
    for worker in workers:
        worker.join()
    assert rejects.total == sum(rejects.counts.values()) == per_thread * threads
    assert len(lines()) == len(reasons)  # well within one interval: the first of each
