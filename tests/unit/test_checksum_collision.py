"""The checksum proves that honest walls hold equal states, not who sent one: a state that
differs in two particles and has the same checksum is made without any search."""

import numpy as np
import pytest

from cavesim.core.digest.shape import WORDS_PER_GROUP, WORKGROUP_SIZE
from cavesim.core.digest.twin import reference_checksum
from cavesim.core.records import EMITTER_WORDS, PARTICLE_WORDS
from nodes.check.checksum_collision import changed_particles, colliding_particles


@pytest.mark.parametrize("particles", [7, 1_000, WORDS_PER_GROUP // PARTICLE_WORDS + 3])
def test_a_colliding_state_differs_in_two_particles_and_has_the_same_checksum(particles):
    rng = np.random.default_rng(particles)
    words = rng.integers(0, 2**32, particles * PARTICLE_WORDS, dtype=np.uint32)
    emitters = rng.integers(0, 2**32, 2 * EMITTER_WORDS, dtype=np.uint32)
    colliding = colliding_particles(words)
    assert reference_checksum(colliding, emitters, 9) == reference_checksum(words, emitters, 9)
    changed = np.flatnonzero(colliding != words)
    assert len(changed) == 2 and len(changed_particles(words, colliding)) == 2
    first, second = changed
    assert second - first == WORKGROUP_SIZE  # one invocation reads both
    assert first // WORDS_PER_GROUP == second // WORDS_PER_GROUP


def test_a_single_changed_word_does_change_the_checksum():
    words = np.arange(100 * PARTICLE_WORDS, dtype=np.uint32)
    emitters = np.zeros(EMITTER_WORDS, dtype=np.uint32)
    changed = words.copy()
    changed[500] ^= 1
    assert reference_checksum(changed, emitters, 0) != reference_checksum(words, emitters, 0)


def test_a_stream_too_short_for_two_words_of_one_invocation_has_no_twin():
    with pytest.raises(ValueError, match="no two differing words"):
        colliding_particles(np.zeros(WORKGROUP_SIZE, dtype=np.uint32))
