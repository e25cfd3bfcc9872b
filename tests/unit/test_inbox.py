"""A node's inbox without a network: what it lets through to the main thread and what it
refuses, counted by reason (nodes/wall/inbox.py)."""

from __future__ import annotations

import logging
import time

import numpy as np
import pytest
import zenoh

from cavesim.core.frame import FrameInput
from cavesim.core.wire import (
    BlockQuery,
    BlockRequest,
    Command,
    ControlMessage,
    FrameMessage,
    InfoRequest,
    SessionKeys,
    StateRequest,
    encode,
)
from cavesim.core.wire.credentials import WALL, generate
from nodes.wall.inbox import (
    BLOCK_BURST,
    QUEUE,
    REPEAT_SPACING,
    STATE_BURST,
    STATE_BYTES,
    BlocksQuery,
    FromMaster,
    MasterPresence,
    NodeInbox,
    NodeView,
    StateQuery,
)

SESSION, RUN, OTHER_RUN, NONCE = "inbox", 0xABC, 0xDEF, 77
MASTER = generate()
MEMBER = MASTER.for_members()
WALLS = {name: MASTER.issue(WALL, name) for name in ("left", "rogue")}  # their own keys
KEYS = SessionKeys(SESSION)


class Payload:
    def __init__(self, data: bytes) -> None:
        self.data = data

    def to_bytes(self) -> bytes:
        return self.data


class Sample:
    def __init__(self, key: str, data: bytes) -> None:
        self.key_expr, self.payload = key, Payload(data)


class Query:
    """A query as zenoh hands one over: once dropped, reading its key raises (as zenoh's
    `Dropped query`)."""

    def __init__(self, key: str, data: bytes | None) -> None:
        self._key = key
        self.payload = None if data is None else Payload(data)
        self.dropped, self.errors = False, []

    @property
    def key_expr(self) -> str:
        if self.dropped:
            raise zenoh.ZError("Dropped query")
        return self._key

    def drop(self) -> None:
        self.dropped = True

    def reply_err(self, text: str) -> None:
        self.errors.append(text)


class Token:
    """A liveliness sample: a token under `key` appeared (PUT) or went away (DELETE)."""

    def __init__(self, key: str, up: bool) -> None:
        self.key_expr = key
        self.kind = zenoh.SampleKind.PUT if up else zenoh.SampleKind.DELETE


def frame(k: int, run: int = RUN, credentials=MASTER) -> Sample:
    return Sample(KEYS.frame, encode(FrameMessage(k, FrameInput(1 / 60, np.eye(3))), SESSION,
                                     credentials, run))


def control(message: ControlMessage, run: int = RUN) -> Sample:
    return Sample(KEYS.control, encode(message, SESSION, MASTER, run))


@pytest.fixture
def inbox() -> NodeInbox:
    return NodeInbox(SESSION, MEMBER, NodeView("front", NONCE, run_id=RUN, done=10))


def delivered(inbox: NodeInbox) -> list:
    events = []
    while (event := inbox.get(0)) is not None:
        events.append(event)
    return events


def test_the_next_frames_of_the_run_pass_and_older_or_foreign_ones_are_refused(inbox):
    for sample in (frame(11), frame(12), frame(9), frame(11, OTHER_RUN)):
        inbox._on_frame(sample)
    assert [e.message.frame for e in delivered(inbox)] == [11, 12]
    assert inbox.rejects.counts == {"stale-frame": 1, "wrong-run": 1}


def test_a_command_older_than_the_newest_frame_is_a_replay(inbox):
    inbox._on_frame(frame(12))
    resync = ControlMessage(11, Command.RESYNC, "front", "left", "a" * 32)
    inbox._on_control(control(resync))
    inbox._on_control(control(ControlMessage(12, Command.RESYNC, "front", "left", "a" * 32)))
    inbox._on_control(control(ControlMessage(12, Command.STOP), OTHER_RUN))
    commands = [e.message for e in delivered(inbox) if isinstance(e.message, ControlMessage)]
    assert [(c.command, c.frame) for c in commands] == [(Command.RESYNC, 12)]
    assert inbox.rejects.counts == {"stale-command": 1, "wrong-run": 1}


def test_only_a_welcome_naming_our_nonce_admits_us_whatever_its_run(inbox):
    inbox._on_control(control(ControlMessage(0, Command.WELCOME, "front", nonce=NONCE + 1)))
    inbox._on_control(control(ControlMessage(0, Command.WELCOME, "left", nonce=NONCE)))
    inbox._on_control(control(ControlMessage(0, Command.WELCOME, "front", nonce=NONCE),
                              OTHER_RUN))
    (welcome,) = delivered(inbox)
    assert isinstance(welcome, FromMaster) and welcome.run_id == OTHER_RUN
    assert inbox.rejects.counts == {"stale-welcome": 1}


def test_a_member_cannot_send_a_frame_or_a_command(inbox):
    from nodes.check.rogue import member_signed

    inbox._on_frame(Sample(KEYS.frame, member_signed(FrameMessage(11, FrameInput(
        1 / 60, np.eye(3))), SESSION, MEMBER.secret, RUN)))
    inbox._on_control(Sample(KEYS.control, member_signed(ControlMessage(11, Command.STOP),
                                                         SESSION, MEMBER.secret, RUN)))
    assert not delivered(inbox) and inbox.rejects.counts == {"not-from-master": 2}


def test_state_queries_need_the_key_the_run_and_this_wall_and_are_rate_limited(inbox):
    request = StateRequest(10, "front", "b" * 32)
    unsigned = Query(KEYS.state("front"), encode(request, SESSION))
    foreign = Query(KEYS.state("front"), encode(request, SESSION, MEMBER, OTHER_RUN))
    for query in (unsigned, foreign, Query(KEYS.state("front"), None)):
        inbox._on_state_query(query)
        assert query.dropped
    signed = [Query(KEYS.state("front"), encode(StateRequest(10, "front", "b" * 32),
                                                SESSION, MEMBER, RUN))
              for _ in range(STATE_BURST + 3)]
    for query in signed:
        inbox._on_state_query(query)
    served = [e for e in delivered(inbox) if isinstance(e, StateQuery)]
    assert len(served) == STATE_BURST and all(q.dropped for q in signed[STATE_BURST:])
    assert inbox.rejects.counts == {"unsigned": 2, "wrong-run": 1, "over-budget": 3}
    assert not unsigned.errors  # only the master's info query is told why


def test_block_queries_need_the_key_the_run_and_this_wall_and_are_rate_limited(inbox):
    request = BlockRequest(10, "front", "b" * 32, BlockQuery.TREE, 2)
    unsigned = Query(KEYS.blocks("front"), encode(request, SESSION))
    foreign = Query(KEYS.blocks("front"), encode(request, SESSION, MEMBER, OTHER_RUN))
    other_wall = Query(KEYS.blocks("front"), encode(BlockRequest(
        10, "left", "b" * 32, BlockQuery.TREE, 2), SESSION, MEMBER, RUN))
    state = Query(KEYS.blocks("front"), encode(StateRequest(10, "front", "b" * 32), SESSION,
                                               MEMBER, RUN))
    for query in (unsigned, foreign, other_wall, state):
        inbox._on_blocks_query(query)
        assert query.dropped
    signed = [Query(KEYS.blocks("front"), encode(BlockRequest(
        10, "front", "b" * 32, BlockQuery.TREE, 2), SESSION, MEMBER, RUN))
              for _ in range(BLOCK_BURST + 2)]
    for query in signed:
        inbox._on_blocks_query(query)
    served = [e for e in delivered(inbox) if isinstance(e, BlocksQuery)]
    assert len(served) == BLOCK_BURST
    assert (served[0].request.query, served[0].request.part) == (request.query, request.part)
    assert inbox.rejects.counts == {"unsigned": 1, "wrong-run": 2, "unexpected": 1,
                                    "over-budget": 2}


def test_an_info_query_whose_signature_fails_is_told_why(inbox):
    stranger = generate()
    query = Query(KEYS.info("front"), encode(InfoRequest(0, "front"), SESSION, stranger, RUN))
    inbox._on_info_query(query)
    assert query.dropped and query.errors == ["bad-signature"]


def test_queries_are_dropped_and_counted_when_the_queue_is_full(inbox):
    for k in range(11, 11 + QUEUE):
        inbox._on_frame(frame(k))  # the master's frames fill the queue (never dropped)
    query = Query(KEYS.info("front"), encode(InfoRequest(0, "front"), SESSION, MASTER, RUN))
    inbox._on_info_query(query)
    assert query.dropped and inbox.dropped == {"InfoQuery": 1}
    assert len(delivered(inbox)) == QUEUE


def state_query(frame: int = 10, asker: str = "left", run: int = RUN) -> Query:
    return Query(KEYS.state("front"), encode(StateRequest(frame, "front", "b" * 32, asker),
                                             SESSION, WALLS[asker], run))


def test_a_query_of_an_earlier_run_is_counted_and_raises_nothing(inbox, caplog):
    """zenoh raises on reading a dropped query's key: the refusal reads it first."""
    caplog.set_level(logging.WARNING)
    earlier = [state_query(run=OTHER_RUN) for _ in range(50)]
    blocks = [Query(KEYS.blocks("front"), encode(BlockRequest(
        10, "front", "b" * 32, BlockQuery.TREE, 2), SESSION, MEMBER, OTHER_RUN))
        for _ in range(50)]
    for query in earlier:
        inbox._on_state_query(query)
    for query in blocks:
        inbox._on_blocks_query(query)
    assert all(q.dropped for q in earlier + blocks) and not delivered(inbox)
    assert inbox.rejects.counts == {"wrong-run": 100}
    assert not any(r.exc_info for r in caplog.records) and len(caplog.records) == 1


def test_a_replayed_query_is_refused_before_it_spends_anyones_budget(inbox):
    """A query captured in this run and sent again, however often, is answered by nothing
    and leaves the asker's budget whole: its next fresh query is served."""
    captured = encode(StateRequest(10, "front", "b" * 32, "left"), SESSION, WALLS["left"], RUN)
    replays = [Query(KEYS.state("front"), captured) for _ in range(1000)]
    for query in replays:
        inbox._on_state_query(query)
    fresh = state_query()
    inbox._on_state_query(fresh)
    assert [e.query for e in delivered(inbox)] == [replays[0], fresh]
    assert inbox.rejects.counts == {"replayed-query": 999}


def test_a_query_of_a_frame_older_than_the_nodes_is_refused_as_stale(inbox):
    inbox._on_state_query(state_query(frame=9))
    inbox._on_state_query(state_query(frame=10))
    assert [e.request.frame for e in delivered(inbox)] == [10]
    assert inbox.rejects.counts == {"stale-query": 1}


def test_each_asker_has_its_own_budget(inbox):
    """A peer that spends its queries and bytes leaves another's resync untouched."""
    flood = [state_query(asker="rogue") for _ in range(STATE_BURST + 20)]
    for query in flood:
        inbox._on_state_query(query)
    first = delivered(inbox)
    inbox.spent(first[0], STATE_BYTES * 4)  # one huge snapshot: in debt
    inbox._on_state_query(state_query(asker="left"))
    served = delivered(inbox)
    assert len(first) == STATE_BURST and [e.request.asker for e in served] == ["left"]
    assert inbox.rejects.counts == {"over-budget": 20}


def test_a_replayed_info_query_is_refused(inbox):
    captured = encode(InfoRequest(0, "front"), SESSION, MASTER, OTHER_RUN)
    for _ in range(10):
        inbox._on_info_query(Query(KEYS.info("front"), captured))
    inbox._on_info_query(Query(KEYS.info("front"), encode(InfoRequest(0, "front"), SESSION,
                                                          MASTER, RUN)))
    assert [e.run_id for e in delivered(inbox)] == [OTHER_RUN, RUN]
    assert inbox.rejects.counts == {"replayed-query": 9}


def test_copies_of_a_queued_frame_are_let_through_one_at_a_time(inbox):
    """The master sends a frame again after a barrier stall; a flood of copies of it is
    counted, not queued (each would make the node publish its report again)."""
    copy = frame(11)
    started = time.monotonic()
    for _ in range(1000):
        inbox._on_frame(copy)
    let_through = 2 + (time.monotonic() - started) / REPEAT_SPACING  # the frame, then copies
    passed = delivered(inbox)
    assert {e.message.frame for e in passed} == {11} and 2 <= len(passed) <= let_through
    assert inbox.rejects.counts == {"repeated-frame": 1000 - len(passed)}


def test_whatever_a_callback_raises_is_counted_in_one_line(inbox, caplog):
    caplog.set_level(logging.INFO)
    on_frame = inbox.rejects.guarded("a frame", inbox._on_frame)
    for _ in range(100):
        on_frame(Sample(KEYS.frame, None))  # a payload of no bytes: TypeError
    assert inbox.rejects.counts == {"callback-failed": 100}
    (line,) = [r for r in caplog.records if "callback-failed" in r.getMessage()
               or "a frame raised" in r.getMessage()]
    assert "a frame raised TypeError" in line.getMessage() and not line.exc_info


def test_a_query_in_another_walls_name_is_refused():
    """A wall's serving budget is spent only by queries that wall signed."""
    inbox = NodeInbox(SESSION, MEMBER, NodeView("front", NONCE, run_id=RUN, done=10))
    forged = encode(StateRequest(10, "front", "b" * 32, "left"), SESSION, WALLS["rogue"], RUN)
    inbox._on_state_query(Query(KEYS.state("front"), forged))
    inbox._on_state_query(state_query(asker="left"))
    assert [e.request.asker for e in delivered(inbox)] == ["left"]
    assert inbox.rejects.counts == {"wrong-signer": 1}


def welcome(run: int) -> Sample:
    return control(ControlMessage(0, Command.WELCOME, "front", nonce=NONCE), run)


def test_while_its_master_is_alive_a_node_refuses_another_masters_welcome_and_frames(inbox):
    for run in (RUN, OTHER_RUN):
        inbox._on_master(Token(KEYS.master_alive(run), up=True))
    inbox._on_control(welcome(OTHER_RUN))
    inbox._on_frame(frame(11, OTHER_RUN))
    inbox._on_frame(frame(11, 0x123))  # of a run whose master is not there: a replay
    assert inbox.refuses_hop(OTHER_RUN, KEYS.control)  # a WELCOME queued before the join
    assert not inbox.refuses_hop(RUN, KEYS.control)
    assert delivered(inbox) == [MasterPresence(RUN, True), MasterPresence(OTHER_RUN, True)]
    assert inbox.rejects.counts == {"other-master": 3, "wrong-run": 1}


def test_once_its_masters_token_is_gone_a_node_takes_a_new_masters_welcome(inbox):
    inbox._on_master(Token(KEYS.master_alive(RUN), up=True))
    inbox._on_master(Token(KEYS.master_alive(OTHER_RUN), up=True))
    inbox._on_master(Token(KEYS.master_alive(RUN), up=False))
    inbox._on_control(welcome(OTHER_RUN))
    *presence, joining = delivered(inbox)
    assert presence[-1] == MasterPresence(RUN, False)
    assert isinstance(joining, FromMaster) and joining.run_id == OTHER_RUN
    assert not inbox.rejects.counts


def test_a_master_token_without_a_run_id_is_refused(inbox):
    inbox._on_master(Token(f"{KEYS.prefix}/master_alive/not-a-run", up=True))
    assert not delivered(inbox) and inbox.rejects.counts == {"bad-master-token": 1}
