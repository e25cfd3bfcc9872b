"""A resync's state confirmed by a second wall, without a network or GL: the resyncing node
is fed replies by a stand-in session, stages into a stand-in GPU state whose checksum is the
GPU checksum's numpy twin, and asks a stand-in confirmer that answers as a node does
(`nodes.blocks.answer`, through the wire's encoding).

A source that is an insider serves a state with the named checksum and two particles traded
(`nodes/check/checksum_collision.py`): the checksum takes it, the confirmer's SHA-256 digest
does not. Peers holding a stolen key of the source answer first with forged streams: the
node loads the honest stream of the same query, so the resync waits no retry for them.
"""

from __future__ import annotations

import time
from types import SimpleNamespace

import numpy as np
import pytest
from zenoh_doubles import RepliesSession, Reply

from cavesim.core.digest.records_digest import records_digest
from cavesim.core.digest.shape import EMITTERS, PARTICLES
from cavesim.core.digest.twin import reference_checksum
from cavesim.core.errors import ProtocolError, StateError
from cavesim.core.records import EMITTER_DTYPE, PARTICLE_BYTES, PARTICLE_WORDS
from cavesim.core.wire import (
    BlockQuery,
    BlockRequest,
    Command,
    ControlMessage,
    SessionKeys,
    SnapshotChunk,
    SnapshotHeader,
    StateRequest,
    decode_envelope,
    encode,
)
from cavesim.core.wire.credentials import generate
from cavesim.core.wire.guards import ServingBudget
from cavesim.core.wire.rejects import RejectCounter
from nodes.blocks import StreamDigests, answer, check_reply, hashed_bytes
from nodes.check.checksum_collision import changed_particles, colliding_particles
from nodes.wall.confirmation import Confirmation, NoConfirmation
from nodes.wall.inbox import STATE_BURST, STATE_BYTES, STATE_RATE, NodeView
from nodes.wall.snapshots import SourceRefused, fetch_snapshot
from nodes.wall.state_service import RESYNC_PAUSE, SOURCE_WAIT, StateService

SESSION, RUN, FRAME, SEED = "confirm", 0x77, 9, 5
WALLS = ("front", "left", "right")  # right resyncs from front, confirmed by left
MASTER = generate()
KEYS = {wall: MASTER.issue("wall", wall) for wall in WALLS}
LIVE, CHUNK = 64, 16  # particles of the state, per chunk
RNG = np.random.default_rng(3)
GENUINE = RNG.integers(0, 2**32, LIVE * PARTICLE_WORDS, dtype=np.uint32)
COLLIDING = colliding_particles(GENUINE)
EMITTER_RECORDS = np.frombuffer(RNG.bytes(2 * EMITTER_DTYPE.itemsize), EMITTER_DTYPE)
CHECKSUM = reference_checksum(GENUINE, EMITTER_RECORDS.view(np.uint32), SEED).digest
THIEVES = 8  # peers holding front's stolen key


class Records:
    """A wall's state in memory, as a node answers block questions about it."""

    def __init__(self, words: np.ndarray, seed: int = SEED) -> None:
        self.words, self.seed = words, seed

    def tree_state(self) -> tuple[int, int, int]:
        return self.seed, self.words.size // PARTICLE_WORDS, len(EMITTER_RECORDS)

    def read_records(self, stream: int, indices: np.ndarray) -> bytes:
        if stream == EMITTERS:
            return EMITTER_RECORDS[indices].tobytes()
        return self.words.reshape(-1, PARTICLE_WORDS)[indices].tobytes()


class StagedState:
    """The resyncing node's GPU state: staged chunk by chunk, committed only with the
    announced checksum (the GPU checksum's twin); what was committed is kept."""

    capacity, emitters = 4 * LIVE, EMITTER_RECORDS

    def __init__(self) -> None:
        self.staged: dict[int, bytes] = {}
        self.committed: np.ndarray | None = None

    def begin_load(self, particles: int) -> None:
        self.staged.clear()

    def write_particle_chunk(self, first: int, data: bytes) -> None:
        self.staged[first] = data

    def commit_load(self, emitters, seed: int, digest: str) -> None:
        words = np.frombuffer(b"".join(self.staged[k] for k in sorted(self.staged)), np.uint32)
        if reference_checksum(words, np.asarray(emitters).view(np.uint32), seed).digest != digest:
            raise StateError("the staged state's checksum is not the announced one")
        self.committed = words

    def checksum(self):
        words = np.zeros(0, np.uint32) if self.committed is None else self.committed
        return reference_checksum(words, EMITTER_RECORDS.view(np.uint32), SEED)

    def keep_history(self, frame: int) -> None:
        pass


def stream(wall: str, words: np.ndarray, seed: int = SEED) -> list[bytes]:
    """A snapshot of `words` announced with the named checksum, signed by `wall`'s key."""
    data = words.tobytes()
    size = CHUNK * PARTICLE_BYTES
    header = SnapshotHeader(FRAME, seed, words.size // PARTICLE_WORDS, CHUNK, CHECKSUM,
                            EMITTER_RECORDS)
    chunks = [SnapshotChunk(FRAME, i, data[i * size:(i + 1) * size])
              for i in range(header.chunks)]
    return [encode(m, SESSION, KEYS[wall], RUN) for m in (header, *chunks)]


AGREED = Records(GENUINE)


def confirmer(held: Records | None = AGREED, wall: str = "left") -> Confirmation:
    """`wall` holding `held` (default: the agreed state), answering each DIGEST question
    through the wire, signed by its own key; with None for `held` it does not answer."""
    def ask(request: BlockRequest):
        if held is None:
            return None
        data = encode(answer(held, request, wall), SESSION, KEYS[wall], RUN)
        envelope = decode_envelope(data, SESSION, KEYS["right"])
        envelope.check_signer("wall", wall)
        return check_reply(envelope.message, request)

    return Confirmation(wall, ask, FRAME, CHECKSUM)


def fetch(replies: list[Reply], state: StagedState, confirmation: Confirmation | None,
          rejects: RejectCounter, failed: set[str] | None = None):
    return fetch_snapshot(RepliesSession(replies), f"cavesim/{SESSION}/state/front", state,
                          b"", lambda data: decode_envelope(data, SESSION, KEYS["right"]),
                          StateRequest(FRAME, "front", CHECKSUM), time.monotonic() + 30,
                          rejects, set() if failed is None else failed, confirmation)


def from_(replier: str, sealed: list[bytes]) -> list[Reply]:
    return [Reply(replier, data) for data in sealed]


def test_the_colliding_twin_has_the_checksum_and_other_particles():
    assert reference_checksum(COLLIDING, EMITTER_RECORDS.view(np.uint32), SEED).digest \
        == CHECKSUM
    assert len(changed_particles(GENUINE, COLLIDING)) == 2


def test_a_colliding_state_from_the_source_itself_is_refused_by_the_confirmer():
    """The source's own key signs it and the checksum takes it: only the second wall's
    digest tells, and the fetch ends (asking that source again would bring the same)."""
    state, rejects, failed = StagedState(), RejectCounter("right"), set()
    with pytest.raises(SourceRefused):
        fetch(from_("front", stream("front", COLLIDING)), state, confirmer(), rejects, failed)
    assert state.committed is None and rejects.counts == {"unconfirmed": 1}
    assert failed == {"front"}


def test_without_a_confirmer_the_checksum_alone_takes_a_colliding_state():
    """Why a resync with no second wall is recorded `unconfirmed`."""
    state = StagedState()
    header = fetch(from_("front", stream("front", COLLIDING)), state, None,
                   RejectCounter("right"))
    assert header is not None and np.array_equal(state.committed, COLLIDING)


def test_the_genuine_state_is_confirmed_and_committed():
    state, rejects = StagedState(), RejectCounter("right")
    confirmation = confirmer()
    header = fetch(from_("front", stream("front", GENUINE)), state, confirmation, rejects)
    assert header is not None and np.array_equal(state.committed, GENUINE)
    assert rejects.counts == {} and confirmation.questions == 2  # particles, emitters
    assert confirmation.said().startswith("confirmed by left (2 digest(s), ")


@pytest.mark.parametrize("held", [Records(GENUINE, seed=SEED + 1),
                                  Records(GENUINE[:-PARTICLE_WORDS])],
                         ids=["another-seed", "fewer-particles"])
def test_a_confirmer_holding_another_seed_or_count_refuses(held):
    state, rejects = StagedState(), RejectCounter("right")
    with pytest.raises(SourceRefused):
        fetch(from_("front", stream("front", GENUINE)), state, confirmer(held), rejects)
    assert state.committed is None and rejects.counts == {"unconfirmed": 1}


def test_a_confirmer_that_does_not_answer_commits_nothing():
    state = StagedState()
    with pytest.raises(NoConfirmation, match="left, named to confirm the state of frame 9"):
        fetch(from_("front", stream("front", GENUINE)), state, confirmer(held=None),
              RejectCounter("right"))
    assert state.committed is None


def test_a_digest_answer_covers_the_records_asked_and_charges_what_it_read():
    """... and a whole stream's digest is read and hashed once per state held."""
    held = Records(GENUINE)
    whole = BlockRequest(FRAME, "left", CHECKSUM, BlockQuery.DIGEST, PARTICLES)
    named = BlockRequest(FRAME, "left", CHECKSUM, BlockQuery.DIGEST, PARTICLES, (3, 40))
    assert answer(held, whole, "left").data == records_digest(PARTICLES, LIVE,
                                                              GENUINE.tobytes())
    records = GENUINE.reshape(LIVE, -1)[[3, 40]].tobytes()
    assert answer(held, named, "left").data == records_digest(PARTICLES, 2, records,
                                                              np.array([3, 40]))
    assert answer(held, named, "left").data != answer(held, whole, "left").data
    assert hashed_bytes(whole) == 0  # made once per state (StreamDigests)
    assert hashed_bytes(named) == 2 * PARTICLE_BYTES
    streams, reads = StreamDigests(), []

    class Counted(Records):
        def read_records(self, stream, indices):
            reads.append(len(indices))
            return super().read_records(stream, indices)

    counted = Counted(GENUINE)
    for _ in range(3):
        assert answer(counted, whole, "left", streams).data == answer(held, whole, "left").data
    assert reads == [LIVE]
    streams.forget()  # the node loaded another state
    answer(counted, whole, "left", streams)
    assert reads == [LIVE, LIVE]
    beyond = BlockRequest(FRAME, "left", CHECKSUM, BlockQuery.DIGEST, PARTICLES, (LIVE,))
    with pytest.raises(ProtocolError, match="records up to 64 asked"):
        answer(held, beyond, "left")


@pytest.mark.parametrize("confirmed", [False, True], ids=["unconfirmed", "confirmed"])
def test_thieves_with_the_source_key_answering_first_cost_no_second_query(confirmed):
    """Eight peers holding front's stolen key each send a forged stream of the named state
    before front does (junk failing the checksum, or with a confirmer, the colliding twin):
    the node refuses each and loads front's own stream from the same query."""
    forged = COLLIDING if confirmed else GENUINE ^ np.uint32(1)
    replies = [reply for i in range(THIEVES) for reply in from_(f"thief{i}",
                                                                  stream("front", forged))]
    state, rejects = StagedState(), RejectCounter("right")
    header = fetch(replies + from_("front", stream("front", GENUINE)), state,
                   confirmer() if confirmed else None, rejects)
    assert header is not None and np.array_equal(state.committed, GENUINE)
    assert rejects.counts == {"unconfirmed" if confirmed else "bad-digest": THIEVES}


def test_a_stream_left_unfinished_first_does_not_hold_back_a_whole_one():
    """A thief with the source's key sends the header and a first chunk, and holds the rest
    back: the source's whole stream that comes meanwhile is loaded."""
    thief = from_("thief", stream("front", GENUINE ^ np.uint32(1))[:2])
    state, rejects = StagedState(), RejectCounter("right")
    header = fetch(thief + from_("front", stream("front", GENUINE)), state, confirmer(),
                   rejects)
    assert header is not None and np.array_equal(state.committed, GENUINE)
    assert rejects.counts == {}


# -- the delay a stolen source key costs a whole resync ---------------------------------------

class Clock:
    """Time that passes only when the node sleeps."""

    def __init__(self) -> None:
        self.now = 1000.0

    def monotonic(self) -> float:
        return self.now

    def sleep(self, seconds: float) -> None:
        self.now += seconds


class Network:
    """The session the resyncing node asks through: every state query reaches THIEVES
    peers holding front's key, which answer first with a broken stream of the named state,
    and front, which serves the asker within its budget (as `nodes/wall/inbox.py` does)."""

    def __init__(self, clock: Clock) -> None:
        self.budget = ServingBudget(STATE_RATE, STATE_BURST, STATE_BYTES, STATE_BYTES,
                                    clock=clock.monotonic)
        self.queries = self.over_budget = 0
        self.thieves = [f"thief{i}" for i in range(THIEVES)]

    def get(self, key, handler, **options) -> None:
        self.queries += 1
        for thief in self.thieves:
            for data in stream("front", GENUINE)[:1] + [self._broken()]:
                handler.callback(Reply(thief, data))
        if self.budget.admit("right"):
            for data in stream("front", GENUINE):
                handler.callback(Reply("front", data))
        else:
            self.over_budget += 1
        handler.drop()

    def liveliness(self):
        return SimpleNamespace(get=lambda key, handler, **options: (
            handler.callback(Reply("front", b"")), handler.drop()))

    @staticmethod
    def _broken() -> bytes:
        return encode(SnapshotChunk(FRAME, 0, bytes(3 * PARTICLE_BYTES)), SESSION,
                      KEYS["front"], RUN)


class ResyncingNode(StateService):
    """The state service of wall `right`, on a stand-in session and GPU state."""

    def __init__(self, session: Network) -> None:
        self.config = SimpleNamespace(name="right", resync="full", session=SESSION,
                                      credentials=KEYS["right"])
        self.session, self.keys = session, SessionKeys(SESSION)
        self.system, self.view = StagedState(), NodeView("right", 0, run_id=RUN)
        self.rejects, self.trajectories, self.last_report = RejectCounter("right"), None, None
        self.stream_digests = StreamDigests()
        self.reports: list = []

    def _seal(self, message) -> bytes:
        return encode(message, SESSION, KEYS["right"], RUN)

    def _publish(self, report, keep: bool = True) -> None:
        self.reports.append(report)

    def _sample(self):
        return None


def test_a_stolen_source_key_delays_a_resync_by_at_most_one_retry_interval(monkeypatch):
    clock = Clock()
    monkeypatch.setattr(time, "monotonic", clock.monotonic)
    monkeypatch.setattr(time, "sleep", clock.sleep)
    network = Network(clock)
    node = ResyncingNode(network)
    started = clock.now
    node._resync(ControlMessage(FRAME, Command.RESYNC, "right", "front", CHECKSUM))
    assert np.array_equal(node.system.committed, GENUINE)
    assert clock.now - started <= RESYNC_PAUSE + SOURCE_WAIT <= 1.5
    assert network.over_budget == 0 and network.queries == 1
    assert node.rejects.counts == {"bad-chunk-size": THIEVES}
    assert [r.digest for r in node.reports] == [node.system.checksum().digest]

