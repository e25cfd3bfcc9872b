"""The GPU checksum: exact against its numpy reference, and sensitive to every bit."""

import numpy as np
import pytest
from scenes import FOUNTAIN, make_scene, particle_cloud

from cavesim.core.records import PARTICLE_WORDS
from cavesim.gpu.engine import FrameInput, ParticleSystem
from cavesim.gpu.engine.checksum import GpuChecksum, reference_sums


@pytest.mark.parametrize("word_count", [1, 255, 4096, 4097, 50_001])
def test_gpu_sums_equal_the_numpy_reference(ctx, word_count):
    words = np.random.default_rng(word_count).integers(0, 2**32, word_count, dtype=np.uint32)
    buffer = ctx.buffer(words.tobytes())
    checksum = GpuChecksum(ctx, word_count)
    assert checksum.buffer_sums(buffer, word_count) == reference_sums(words)
    buffer.release()


@pytest.fixture
def system(ctx):
    system = ParticleSystem(ctx, make_scene(emitters=[FOUNTAIN], capacity=3000))
    system.write_particles(particle_cloud(2001))
    return system


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
