"""The checksum's hash tree, kept readable (the GPU's block sums against the numpy twin's are
in test_checksum.py): a node's history ring keeps each frame's blocks, and the
tree's shape maps an invocation to exactly the records whose words it summed."""

import numpy as np
from scenes import FOUNTAIN, make_scene, particle_cloud

from cavesim.core.digest.history import HistoryRing
from cavesim.core.digest.shape import (
    EMITTERS,
    PARTICLES,
    WORDS_PER_GROUP,
    block_of_record,
    children,
    invocation_records,
)
from cavesim.core.digest.twin import reference_levels, reference_sums
from cavesim.core.records import EMITTER_DTYPE, EMITTER_WORDS, PARTICLE_DTYPE, PARTICLE_WORDS
from cavesim.gpu.engine import FrameInput, ParticleSystem


def test_an_invocation_covers_exactly_the_records_whose_words_it_summed():
    records = 5000
    words = np.zeros(records * PARTICLE_WORDS, np.uint32)
    base = reference_sums(words)
    rng = np.random.default_rng(0)
    for record in rng.integers(0, records, 20):
        for word in range(PARTICLE_WORDS):
            changed = words.copy()
            changed[record * PARTICLE_WORDS + word] ^= 1
            (differing,) = np.flatnonzero((reference_sums(changed) != base).any(axis=1))
            group, thread = divmod(int(differing), 64)
            assert record in invocation_records(PARTICLES, group, thread, records)
            assert group == (record * PARTICLE_WORDS + word) // WORDS_PER_GROUP
    assert block_of_record(PARTICLES, 1638) == 0 and block_of_record(PARTICLES, 1639) == 1
    assert len(invocation_records(PARTICLES, 0, 5, records)) == 256
    assert list(invocation_records(EMITTERS, 0, 1, 3)) == [0]  # word 1 of 12
    assert list(invocation_records(EMITTERS, 0, 5, 3)) == [1]
    assert list(children(2, 1, 100)) == list(range(64, 100))


def test_the_history_ring_keeps_the_newest_frames_and_forgets_a_replaced_future():
    ring = HistoryRing(3)
    slots = [ring.keep(k, k, 0) for k in (1, 2, 3, 4)]
    assert slots[3] == slots[0]  # frame 1's slot went to frame 4
    assert [e.frame for e in ring.up_to(10)] == [2, 3, 4]
    assert ring.keep(3, 30, 0) == slots[2]  # frame 3 again (a resync): its slot, 4 dropped
    assert [(e.frame, e.particles) for e in ring.up_to(10)] == [(2, 2), (3, 30)]
    assert [e.frame for e in ring.up_to(2)] == [2]
    ring.clear()
    assert ring.up_to(10) == []


def test_a_system_keeps_each_frames_blocks_and_reads_them_back(ctx):
    system = ParticleSystem(ctx, make_scene(emitters=[FOUNTAIN], capacity=20_000, seed=3))
    try:
        kept = {}
        for k in range(1, 6):
            system.step(FrameInput(1 / 60, np.eye(3)))
            system.checksum()
            system.keep_history(k)
            particles = system.read_particles().view(np.uint32)
            emitters = system.read_emitters().view(np.uint32)
            kept[k] = reference_levels(particles, emitters)[1]
        last = len(kept[5])
        for entry, items in system.history(np.arange(last), 5):
            live = len(kept[entry.frame])
            np.testing.assert_array_equal(items[:live], kept[entry.frame])
        assert [e.frame for e, _ in system.history(np.arange(1), 3)] == [1, 2, 3]
        # the tree read on demand is the current state's, whatever ran before
        system.step(FrameInput(1 / 60, np.eye(3)))
        words = system.read_particles().view(np.uint32), system.read_emitters().view(np.uint32)
        top = reference_levels(*words)[2]
        np.testing.assert_array_equal(system.tree_items(2, np.arange(len(top))), top)
    finally:
        system.release()


def test_records_read_by_index_and_a_patch_replaces_only_those(ctx):
    system = ParticleSystem(ctx, make_scene(emitters=[FOUNTAIN], capacity=5000, seed=4))
    try:
        cloud = particle_cloud(3000, seed=1)
        system.write_particles(cloud)
        before = system.checksum()
        picked = np.array([0, 1, 2, 700, 2999])
        assert system.read_records(PARTICLES, picked) == cloud[picked].tobytes()
        assert system.read_records(EMITTERS, np.array([0])) == \
            system.read_emitters()[:1].tobytes()
        patched = cloud.copy()
        patched["pos"][700, 1] += 1.0
        system.begin_patch()
        system.write_particle_chunk(700, patched[700:701].tobytes())
        system.commit_load()
        np.testing.assert_array_equal(system.read_particles(), patched)
        assert system.checksum() != before
    finally:
        system.release()


def test_empty_streams_have_no_record_to_read(ctx):
    system = ParticleSystem(ctx, make_scene(capacity=100))
    try:
        assert system.read_records(PARTICLES, np.array([], np.int64)) == b""
        assert np.zeros(0, EMITTER_DTYPE).size == len(system.emitters) == 0
        assert PARTICLE_DTYPE.itemsize == PARTICLE_WORDS * 4 and EMITTER_WORDS == 4
    finally:
        system.release()
