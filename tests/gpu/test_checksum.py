"""The GPU checksum: exact against its numpy twin, and sensitive to every bit, the order, the
counts and the seed."""

import numpy as np
import pytest
from scenes import FOUNTAIN, make_scene, particle_cloud

from cavesim.core.digest.shape import ITEM_WORDS, plan
from cavesim.core.digest.twin import reference_checksum, reference_levels
from cavesim.core.records import EMITTER_WORDS, PARTICLE_WORDS
from cavesim.gpu.engine import FrameInput, ParticleSystem
from cavesim.gpu.engine.checksum import RESULT_BYTES, GpuChecksum
from cavesim.gpu.gl.fence import GpuFence

SEED = 2**63 + 0x1234_5678_9ABC  # both 32-bit halves matter


class State:
    """Random words of both streams in GPU buffers, checksummed as the engine does."""

    def __init__(self, ctx, particles: int, emitters: int, seed: int = 0) -> None:
        rng = np.random.default_rng(seed)
        self.particle_words = rng.integers(0, 2**32, particles * PARTICLE_WORDS, np.uint32)
        self.emitter_words = rng.integers(0, 2**32, emitters * EMITTER_WORDS, np.uint32)
        self.checksum = GpuChecksum(ctx, particles, emitters, GpuFence(ctx))
        self.buffers = [ctx.buffer(reserve=max(w.nbytes, 4))
                        for w in (self.particle_words, self.emitter_words)]
        self.upload()

    def upload(self) -> None:
        for buffer, words in zip(self.buffers, (self.particle_words, self.emitter_words),
                                 strict=True):
            if words.size:
                buffer.write(words.tobytes())

    def gpu(self, seed: int = SEED, counts=None):
        counts = counts or (self.particle_words.size // PARTICLE_WORDS,
                            self.emitter_words.size // EMITTER_WORDS)
        return self.checksum.state(self.buffers[0], counts[0], self.buffers[1], counts[1], seed)

    def on_gpu_counts(self, seed: int = SEED):
        """The digest when only the GPU's counts buffer holds the counts (indirect path)."""
        counts = (self.particle_words.size // PARTICLE_WORDS,
                  self.emitter_words.size // EMITTER_WORDS)
        self.checksum.counts.write(np.array(counts, "<u4").tobytes())
        self.checksum.run(self.buffers[0], self.buffers[1], seed)
        return self.checksum.read()

    def release(self) -> None:
        self.checksum.release()
        for buffer in self.buffers:
            buffer.release()


@pytest.fixture
def state_of(ctx):
    made = []

    def make(particles: int, emitters: int, seed: int = 0) -> State:
        made.append(State(ctx, particles, emitters, seed))
        return made[-1]

    yield make
    for state in made:
        state.release()


# sizes: empty, one record, many fold-1 items, and (110,000) several fold-2 items
@pytest.mark.parametrize(("particles", "emitters"),
                         [(0, 0), (1, 0), (0, 3), (2001, 5), (110_000, 7), (3, 4096)])
def test_gpu_digest_equals_the_numpy_twin(state_of, particles, emitters):
    state = state_of(particles, emitters, seed=particles + emitters)
    expected = reference_checksum(state.particle_words, state.emitter_words, SEED)
    assert (expected.particles, expected.emitters) == (particles, emitters)
    assert state.gpu() == expected
    assert state.on_gpu_counts() == expected


def test_the_largest_sizes_fold_through_every_level():
    sums, level_1, level_2 = plan(110_000, 7).items
    assert level_1 > 64 and level_2 > 1  # the 110,000-particle case above tests both levels
    assert plan(0, 0).items == (0, 0, 0)


def test_counts_written_on_the_gpu_come_back_with_the_digest(ctx, state_of):
    """A caller that does not know the live count: a GPU copy into `counts`, one read."""
    state = state_of(500, 2)
    source = ctx.buffer(np.array([0, 321, 1], "<u4").tobytes())
    ctx.copy_buffer(state.checksum.counts, source, size=8, read_offset=4)
    state.checksum.run(state.buffers[0], state.buffers[1], SEED)
    checksum = state.checksum.read()
    assert (checksum.particles, checksum.emitters) == (321, 1)
    assert checksum == state.gpu(counts=(321, 1))
    assert state.checksum.result.size == RESULT_BYTES
    source.release()


@pytest.mark.parametrize("stream", ["particles", "emitters"])
def test_every_word_of_a_small_state_is_covered(state_of, stream):
    """Each word, flipped at its lowest, a middle and its highest bit, changes the digest."""
    state = state_of(3, 2)
    before = state.gpu().digest
    words = state.particle_words if stream == "particles" else state.emitter_words
    for index in range(words.size):
        for bit in (0, 17, 31):
            words[index] ^= np.uint32(1 << bit)
            state.upload()
            assert state.gpu().digest != before, f"bit {bit} of word {index}"
            words[index] ^= np.uint32(1 << bit)
    state.upload()
    assert state.gpu().digest == before


@pytest.mark.parametrize("where", [0, 1_048_575, 1_048_576, 1_099_999])
def test_a_flipped_word_far_into_a_large_state_changes_the_digest(state_of, where):
    """Words in the first and a later sums group, either side of a fold-2 boundary
    (fold 2's first item covers 64 · 64 sums = 64 groups = 1,048,576 words)."""
    state = state_of(110_000, 1)
    before = state.gpu().digest
    state.particle_words[where] ^= np.uint32(1 << 9)
    state.upload()
    assert state.gpu().digest != before


def test_order_counts_and_seed_are_covered(state_of):
    state = state_of(40, 3)
    before = state.gpu().digest
    digests = {before}
    # words, records, far apart, and two words that one invocation sums (64 words apart)
    swaps = [(0, 1), (0, PARTICLE_WORDS), (57, 399), (3, 3 + 64 * 5)]
    for a, b in swaps:
        swapped = state.particle_words.copy()
        swapped[[a, b]] = swapped[[b, a]]
        state.particle_words, original = swapped, state.particle_words
        state.upload()
        digests.add(state.gpu().digest)
        state.particle_words = original
    state.emitter_words[[0, EMITTER_WORDS]] = state.emitter_words[[EMITTER_WORDS, 0]]
    state.upload()
    digests.add(state.gpu().digest)
    state.emitter_words[[0, EMITTER_WORDS]] = state.emitter_words[[EMITTER_WORDS, 0]]
    state.upload()
    for counts in [(39, 3), (40, 2), (0, 3), (40, 0)]:
        digests.add(state.gpu(counts=counts).digest)
    for seed in [SEED ^ 1, SEED ^ (1 << 40), SEED ^ (1 << 63), 0]:
        digests.add(state.gpu(seed=seed).digest)
    assert len(digests) == 1 + len(swaps) + 1 + 4 + 4
    assert state.gpu().digest == before


@pytest.fixture
def system(ctx):
    system = ParticleSystem(ctx, make_scene(emitters=[FOUNTAIN], capacity=3000))
    system.write_particles(particle_cloud(2001))
    return system


def test_the_engine_checksum_is_the_twins(system):
    particles, emitters = system.read_particles(), system.read_emitters()
    emitters["accumulator"] = 0.375
    load(system, particles, emitters)
    assert system.checksum() == reference_checksum(particles.view(np.uint32),
                                                   emitters.view(np.uint32), system.scene.seed)


@pytest.mark.parametrize("where", ["first", "middle", "last"])
@pytest.mark.parametrize("word", range(PARTICLE_WORDS))
def test_one_flipped_bit_changes_the_checksum(system, where, word):
    records = system.read_particles()
    before = system.checksum()
    index = {"first": 0, "middle": len(records) // 2, "last": len(records) - 1}[where]
    words = records.view(np.uint32).reshape(len(records), PARTICLE_WORDS)
    for bit in (0, 17, 31):
        flipped = words.copy()
        flipped[index, word] ^= np.uint32(1 << bit)
        system.write_particles(flipped.reshape(-1).view(records.dtype))
        assert system.checksum().digest != before.digest, f"bit {bit} of word {word}"
    system.write_particles(records)
    assert system.checksum() == before


@pytest.mark.parametrize("word", range(EMITTER_WORDS))
def test_one_flipped_emitter_bit_changes_the_checksum(system, word):
    records, emitters = system.read_particles(), system.read_emitters()
    before = system.checksum()
    for bit in (0, 17, 31):
        flipped = emitters.copy()
        flipped.view(np.uint32)[word] ^= np.uint32(1 << bit)
        load(system, records, flipped)
        assert system.checksum().digest != before.digest, f"bit {bit} of word {word}"
    load(system, records, emitters)
    assert system.checksum() == before


def test_order_count_and_emitters_are_covered(system):
    records = system.read_particles()
    before = system.checksum().digest
    swapped = records.copy()
    swapped[[3, 4]] = swapped[[4, 3]]
    system.write_particles(swapped)
    assert system.checksum().digest != before
    system.write_particles(records[:-1])
    assert system.checksum().digest != before
    emitters = system.read_emitters()
    changed = emitters.copy()
    changed["accumulator"] += 0.25
    load(system, records, changed)
    assert system.checksum().digest != before
    load(system, records, emitters)
    assert system.checksum().digest == before


def load(system: ParticleSystem, particles: np.ndarray, emitters: np.ndarray) -> None:
    system.begin_load(len(particles))
    system.write_particle_chunk(0, particles.tobytes())
    system.commit_load(emitters)


def test_bytes_past_the_live_count_are_not_hashed(ctx):
    """A frame that leaves stale particles in the buffer tail hashes like a fresh one."""
    scene = make_scene(capacity=100)
    cloud = particle_cloud(50)
    stale = ParticleSystem(ctx, scene)
    stale.write_particles(particle_cloud(100, seed=9))
    stale.write_particles(cloud)
    fresh = ParticleSystem(ctx, scene)
    fresh.write_particles(cloud)
    assert stale.checksum() == fresh.checksum()
    frame = FrameInput(1 / 60, np.eye(3, dtype=np.float32))
    stale.step(frame)
    fresh.step(frame)
    assert stale.checksum() == fresh.checksum()


def test_counts_beyond_the_buffers_are_refused(state_of):
    state = state_of(10, 1)
    with pytest.raises(ValueError, match="counts must be within"):
        state.gpu(counts=(11, 1))
    with pytest.raises(ValueError, match="seed must be within"):
        state.gpu(seed=-1)


@pytest.mark.parametrize(("particles", "emitters", "seed"),
                         [(1, 0, 1), (2001, 5, 2), (110_000, 7, 3), (0, 3, 4)])
def test_gpu_block_sums_equal_the_numpy_twins_at_every_level(state_of, particles, emitters,
                                                             seed):
    state = state_of(particles, emitters, seed)
    state.gpu()
    expected = reference_levels(state.particle_words, state.emitter_words)
    for level, items in enumerate(expected):
        assert len(items) == plan(particles, emitters).items[level]
        every = np.arange(len(items))
        np.testing.assert_array_equal(state.checksum.read_items(level, every), items)
        some = every[::7]  # scattered runs read piecewise
        np.testing.assert_array_equal(state.checksum.read_items(level, some), items[some])
        assert items.shape[1] == ITEM_WORDS[level]
