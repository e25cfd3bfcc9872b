"""Delta resync without a network: a diverged system fetches from a healthy one only the
records under the differing blocks of their checksum trees, and loads them only if the
patched state has the named checksum; anything else is refused and changes nothing. And a
node's answers to block questions: only about the state it holds, within that state."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from scenes import FOUNTAIN, make_scene, particle_cloud
from test_snapshot import CapturedQuery
from zenoh_doubles import RepliesSession, Reply

from cavesim.core.errors import ProtocolError
from cavesim.core.records import PARTICLE_DTYPE
from cavesim.core.wire import BlockQuery, BlockRequest
from cavesim.core.wire.credentials import generate
from cavesim.core.wire.envelope import decode, decode_envelope, encode
from cavesim.core.wire.rejects import RejectCounter
from cavesim.gpu.engine import FrameInput, ParticleSystem
from nodes.blocks import BlockAsker, answer, check_reply, serve_blocks
from nodes.check.checksum_collision import colliding_particles
from nodes.wall.confirmation import Confirmation
from nodes.wall.delta import DeltaRefused, fetch_delta

SESSION, KEY = "delta", generate().issue("wall", "front")  # the source's own key
FRAME, PARTICLES = 30, 40_000  # 25 blocks of the checksum's tree


class Source:
    """A healthy node's answers, through the wire's encoding; counts questions and bytes."""

    def __init__(self, system: ParticleSystem, tamper=None) -> None:
        self.system, self.tamper = system, tamper
        self.questions: list[BlockRequest] = []
        self.bytes = 0

    def __call__(self, request: BlockRequest):
        self.questions.append(request)
        reply = answer(self.system, decode(encode(request, SESSION, KEY), SESSION, KEY), "front")
        if self.tamper is not None:
            reply = self.tamper(reply)
        data = encode(reply, SESSION, KEY)
        self.bytes += len(data)
        return check_reply(decode(data, SESSION, KEY), request)


def system_with(ctx, cloud: np.ndarray, seed: int = 7) -> ParticleSystem:
    system = ParticleSystem(ctx, make_scene(emitters=[FOUNTAIN], capacity=PARTICLES, seed=seed))
    system.write_particles(cloud)
    system.step(FrameInput(1 / 60, np.eye(3)))  # the emitters move on, the cloud too
    return system


@pytest.fixture
def pair(ctx):
    cloud = particle_cloud(PARTICLES - 1000, seed=3)
    made = [system_with(ctx, cloud), system_with(ctx, cloud)]
    yield made
    for system in made:
        system.release()


def flip(system: ParticleSystem, particle: int, word: int, bit: int) -> None:
    records = system.read_particles()
    records.view(np.uint32).reshape(len(records), -1)[particle, word] ^= np.uint32(1 << bit)
    system.write_particles(records)


def state(system: ParticleSystem) -> tuple:
    return (system.checksum(), system.scene.seed, system.read_emitters().tobytes(),
            system.read_particles().tobytes())


def test_a_flipped_bit_heals_by_fetching_one_invocations_records(pair):
    healthy, odd = pair
    flip(odd, 20_000, 4, 9)
    source = Source(healthy)
    delta = fetch_delta(odd, source, FRAME, "front", healthy.checksum().digest)
    assert state(odd) == state(healthy)
    assert (delta.blocks, delta.invocations) == (1, 1) and delta.records <= 256
    assert [q.query for q in source.questions] == [BlockQuery.TREE] * 3 + [BlockQuery.RECORDS]
    full = healthy.live_count * PARTICLE_DTYPE.itemsize
    assert source.bytes < 13_000 < full // 100  # vs 1.6 MB; each reply has its wall's card


def test_the_emitter_stream_and_the_seed_heal_by_delta_too(ctx):
    cloud = particle_cloud(20_000, seed=4)  # new particles differ: 2 of 14 blocks
    healthy, odd = system_with(ctx, cloud), system_with(ctx, cloud, seed=8)
    try:
        emitters = odd.read_emitters()
        emitters["serial"][0] += 1
        odd.begin_patch()
        odd.commit_load(emitters)
        fetch_delta(odd, Source(healthy), FRAME, "front", healthy.checksum().digest)
        assert state(odd) == state(healthy) and odd.scene.seed == 7
    finally:
        healthy.release()
        odd.release()


def test_other_live_counts_are_refused_and_change_nothing(pair):
    healthy, odd = pair
    odd.write_particles(odd.read_particles()[:-1])
    before = state(odd)
    with pytest.raises(DeltaRefused, match="live counts differ"):
        fetch_delta(odd, Source(healthy), FRAME, "front", healthy.checksum().digest)
    assert state(odd) == before


def test_forged_records_are_refused_and_change_nothing(pair):
    healthy, odd = pair
    flip(odd, 100, 0, 3)
    before = state(odd)

    def forge(reply):
        if reply.query is not BlockQuery.RECORDS:
            return reply
        return type(reply)(**{**reply.__dict__, "data": bytes(len(reply.data))})

    with pytest.raises(DeltaRefused, match="not the named one") as refused:
        fetch_delta(odd, Source(healthy, forge), FRAME, "front", healthy.checksum().digest)
    assert refused.value.bad_data and state(odd) == before


def test_a_colliding_delta_from_an_insider_source_is_refused_by_the_confirmer(ctx, pair):
    """The source holds a state with the named checksum and two particles traded within the
    invocation the odd node's flipped bit lies in: its tree agrees with the healthy one's,
    so the delta fetches the traded records, and the checksum takes the patched state. The
    second wall's digest of the same records refuses it; nothing is loaded."""
    healthy, odd = pair
    digest = healthy.checksum().digest
    insider = system_with(ctx, particle_cloud(PARTICLES - 1000, seed=3))
    try:
        genuine = healthy.read_particles().view(np.uint32).reshape(-1)
        insider.write_particles(colliding_particles(genuine).view(PARTICLE_DTYPE))
        assert insider.checksum().digest == digest
        flip(odd, 0, 0, 3)  # in the invocation of the traded words
        before = state(odd)
        confirmation = Confirmation("left", lambda request: answer(healthy, request, "left"),
                                    FRAME, digest)
        with pytest.raises(DeltaRefused, match="not confirmed") as refused:
            fetch_delta(odd, Source(insider), FRAME, "front", digest, confirmation)
        assert refused.value.refusal.reason == "unconfirmed" and refused.value.bad_data
        assert state(odd) == before
        fetch_delta(odd, Source(insider), FRAME, "front", digest)  # unconfirmed: taken
        assert state(odd) == state(insider) != state(healthy)
    finally:
        insider.release()


def test_a_confirmed_delta_heals(pair):
    healthy, odd = pair
    digest = healthy.checksum().digest
    flip(odd, 20_000, 4, 9)
    confirmation = Confirmation("left", lambda request: answer(healthy, request, "left"),
                                FRAME, digest)
    fetch_delta(odd, Source(healthy), FRAME, "front", digest, confirmation)
    assert state(odd) == state(healthy) and confirmation.questions == 2  # a page, emitters


def test_no_answer_or_too_many_differing_blocks_are_refused(pair):
    healthy, odd = pair
    with pytest.raises(DeltaRefused, match="did not answer a TREE"):
        fetch_delta(odd, lambda request: None, FRAME, "front", healthy.checksum().digest)
    records = odd.read_particles()
    records["pos"][:, 2] += 1.0  # every block differs
    odd.write_particles(records)
    with pytest.raises(DeltaRefused, match="blocks differ"):
        fetch_delta(odd, Source(healthy), FRAME, "front", healthy.checksum().digest)


def test_a_node_answers_only_about_the_state_it_holds_and_within_it(pair):
    healthy, _ = pair
    digest = healthy.checksum().digest

    def served(request: BlockRequest, held=(FRAME, digest)) -> tuple[list, bool]:
        query = CapturedQuery()
        errors = []
        query.reply_err = errors.append
        serve_blocks(query, "cavesim/delta/blocks/front", healthy, "front", held, request,
                     lambda message: encode(message, SESSION, KEY))
        return errors or [decode(r, SESSION, KEY) for r in query.replies], query.dropped

    top = BlockRequest(FRAME, "front", digest, BlockQuery.TREE, 2)
    (reply,), dropped = served(top)
    assert dropped and check_reply(reply, top).particles == healthy.live_count
    (refusal,), _ = served(top, held=(FRAME - 1, digest))
    assert refusal.startswith("not-held")
    beyond = BlockRequest(FRAME, "front", digest, BlockQuery.RECORDS, 0, (healthy.live_count,))
    (refusal,), _ = served(beyond)
    assert refusal.startswith("bad-index")
    with pytest.raises(ProtocolError, match="bad-size"):
        check_reply(reply, BlockRequest(FRAME, "front", digest, BlockQuery.TREE, 2, (0, 1)))


def test_an_asker_counts_bad_replies_and_follows_the_first_good_replier(pair):
    healthy, _ = pair
    digest = healthy.checksum().digest
    request = BlockRequest(FRAME, "front", digest, BlockQuery.TREE, 2)
    good = answer(healthy, request, "front")

    def sealed(message, run=1):
        return encode(message, SESSION, KEY, run)

    def opened(data):
        envelope = decode_envelope(data, SESSION, KEY)
        if envelope.run_id != 1:
            raise ProtocolError("wrong-run", "another run's reply")
        return envelope

    replies = [Reply("a", refusal="not-held: asked about frame 30"),
               Reply("b", sealed(good, run=2)),  # another run's
               Reply("c", sealed(replace(good, node="left"))),  # another node's
               Reply("d", sealed(replace(good, data=good.data * 2))),  # the wrong size
               Reply("b", sealed(good)),  # a failed replier is not heard again
               Reply("e", sealed(good)), Reply("f", sealed(good))]
    rejects = RejectCounter("test")
    ask = BlockAsker(RepliesSession(replies), "cavesim/delta/blocks/front", sealed, opened, rejects)
    assert ask(request) == good and ask.replier == "e"
    assert rejects.counts == {"wrong-run": 1, "wrong-reply": 1, "bad-size": 1}
    assert ask.failed == {"b", "c", "d"} and ask.refusal.startswith("not-held")
    ask.session = RepliesSession([Reply("f", sealed(good)), Reply("e", sealed(good))])
    assert ask(request) == good and ask.replier == "e"  # the replier followed stays
    assert ask.bytes > 2 * len(sealed(good))
