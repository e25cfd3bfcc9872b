"""Waiting for replies over real zenoh sessions on loopback: the wait ends at its deadline
whatever a replier does, replies beyond the buffer are dropped and counted while the
replier goes on unblocked, and a replier not listened to is never buffered."""

from __future__ import annotations

import threading
import time

import pytest
import zenoh

from cavesim.core.wire.network import NetworkSettings, open_session
from cavesim.core.wire.replies import REPLY_FLOOR, anyone_alive, asking
from nodes.launch.launcher import free_port

KEY = "cavesim/replies-test/q"
ALIVE = "cavesim/replies-test/alive"
EVERY_REPLY = zenoh.ConsolidationMode.NONE  # as the wire asks: the default keeps one per key


@pytest.fixture
def pair():
    """An asking session and a replying one, connected on loopback."""
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    with open_session(NetworkSettings(listen=(endpoint,))) as asker, \
            open_session(NetworkSettings(connect=(endpoint,))) as replier:
        anyone_alive(replier, ALIVE, time.monotonic() + 5)  # the link is up before a query
        yield asker, replier


def ask_until_answered(asker, deadline: float, limit_bytes: int, **options):
    """The first query's replies that any queryable answered (the link may take a moment)."""
    while time.monotonic() < deadline:
        with asking(asker, KEY, min(time.monotonic() + 2, deadline), limit_bytes,
                    consolidation=EVERY_REPLY, **options) as replies:
            got = list(replies)
            if got or replies.dropped:
                return replies, got
    raise AssertionError("no queryable answered")


def test_a_replier_that_holds_its_query_is_waited_on_only_until_the_deadline(pair):
    asker, replier = pair
    held = []

    def answer_and_hold(query: zenoh.Query) -> None:
        query.reply(KEY, b"one")
        held.append(query)  # never dropped: the query would stay open for ever

    queryable = replier.declare_queryable(KEY, answer_and_hold)
    try:
        ask_until_answered(asker, time.monotonic() + 10, 2**20)  # the link is up
        started = time.monotonic()
        with asking(asker, KEY, started + 1.0, 2**20, consolidation=EVERY_REPLY) as replies:
            got = [r.ok.payload.to_bytes() for r in replies]
        waited = time.monotonic() - started
    finally:
        queryable.undeclare()
        for query in held:
            query.drop()
    assert got == [b"one"] and 0.9 < waited < 5.0


def test_replies_beyond_the_buffer_are_dropped_and_counted_without_blocking(pair):
    asker, replier = pair
    sent = threading.Event()

    def flood(query: zenoh.Query) -> None:
        for _ in range(50):
            query.reply(KEY, bytes(REPLY_FLOOR))
        query.drop()
        sent.set()

    queryable = replier.declare_queryable(KEY, flood)
    try:
        ask_until_answered(asker, time.monotonic() + 10, 2**20)  # the queryable is known
        sent.clear()
        with asking(asker, KEY, time.monotonic() + 10, 4 * REPLY_FLOOR,
                    consolidation=EVERY_REPLY) as replies:
            assert sent.wait(10), "the replier was blocked by a reader that did not read"
            time.sleep(0.5)  # the last replies reach the callback
            got = list(replies)
    finally:
        queryable.undeclare()
    assert len(got) == 4 and replies.overflowed == replies.dropped == 46


def test_a_replier_not_listened_to_is_never_buffered(pair):
    asker, replier = pair
    queryable = replier.declare_queryable(KEY, lambda query: (query.reply(KEY, b"x"),
                                                              query.drop()))
    try:
        replies, got = ask_until_answered(asker, time.monotonic() + 10, 2**20,
                                          listen=lambda id: False)
    finally:
        queryable.undeclare()
    assert got == [] and replies.dropped == 1 and replies.overflowed == 0


def test_liveliness_is_answered_or_not_by_the_deadline(pair):
    asker, replier = pair
    started = time.monotonic()
    assert not anyone_alive(asker, "cavesim/replies-test/nobody", started + 0.5)
    assert time.monotonic() - started < 5.0
    token = replier.liveliness().declare_token("cavesim/replies-test/somebody")
    try:
        deadline = time.monotonic() + 10
        while not anyone_alive(asker, "cavesim/replies-test/somebody", deadline):
            assert time.monotonic() < deadline
    finally:
        token.undeclare()
