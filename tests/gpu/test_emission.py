"""Emission on the GPU: exact totals and lifetimes, order, randomness, capacity."""

import numpy as np
import pytest
from scenes import FOUNTAIN, make_scene

from cavesim.core.random_texture import draw_transform
from cavesim.core.twin.system import TwinSystem
from cavesim.gpu.engine import FrameInput, ParticleSystem


def emitter(**overrides):
    return dict(FOUNTAIN, **overrides)


def frames(count, dt=1 / 60, seed=3, size=64):
    rng = np.random.default_rng(seed)
    return [FrameInput(dt, draw_transform(rng, size)) for _ in range(count)]


@pytest.mark.parametrize(("rate", "dt", "steps", "expected"), [
    (12.5, 1 / 60, 600, 125),  # 10 s at 60 Hz
    (1000.0, 1 / 60, 60, 1000),
    (0.5, 1 / 30, 300, 5),
    (7.0, 1 / 64, 640, 70),
])
def test_emission_totals_are_exact(ctx, rate, dt, steps, expected):
    scene = make_scene(emitters=[emitter(rate=rate, lifetime=[1000.0, 1000.0])],
                       capacity=2000, drag=False)
    system = ParticleSystem(ctx, scene)
    for frame in frames(steps, dt):
        system.step(frame)
    state = system.read_emitters()[0]
    assert system.live_count == expected
    assert int(state["serial"]) + int(state["count"]) == expected


@pytest.mark.parametrize(("dt", "frames_alive"), [(1 / 60, 30), (1 / 64, 32)])
def test_lifetimes_are_exact_to_the_frame(ctx, dt, frames_alive):
    """One particle a frame, each living 0.5 s: exactly 0.5/dt of them are ever alive."""
    scene = make_scene(emitters=[emitter(rate=float(round(1 / dt)), lifetime=[0.5, 0.5])],
                       drag=False)
    system = ParticleSystem(ctx, scene)
    counts = []
    for frame in frames(3 * frames_alive, dt):
        system.step(frame)
        counts.append(system.live_count)
    assert counts[:frames_alive] == list(range(1, frames_alive + 1))
    assert set(counts[frames_alive:]) == {frames_alive}
    ages = system.read_particles()["age"]
    assert ages.max() < 0.5 and sorted(ages, reverse=True) == list(ages)


def test_many_emitters_in_batches_match_the_twin_in_order(ctx):
    """Several emitters and several GS batches a frame: the order is the twin's order."""
    scene = make_scene(emitters=[emitter(name="a", rate=6000.0),
                                 emitter(name="b", rate=9000.0, particle_class="dust",
                                         position=[1.0, 1.0, 1.0])], capacity=20000)
    gpu, twin = ParticleSystem(ctx, scene), TwinSystem(scene)
    for frame in frames(20):
        gpu.step(frame)
        twin.step(frame)
        assert gpu.live_count == twin.live_count
    records = gpu.read_particles()
    np.testing.assert_array_equal(records["class_id"], twin.particles.class_id)
    np.testing.assert_array_equal(records["age"], twin.particles.age)
    np.testing.assert_allclose(records["lifetime"], twin.particles.lifetime, rtol=1e-6)
    np.testing.assert_allclose(records["pos"], twin.particles.pos, rtol=1e-5, atol=1e-4)
    np.testing.assert_allclose(records["vel"], twin.particles.vel, rtol=1e-5, atol=1e-4)
    np.testing.assert_array_equal(gpu.read_emitters(), twin.emitters)


def test_hundreds_of_emitters_match_the_twin(ctx):
    """The emitter table is a texture: far more emitters than uniform arrays would hold on
    the smallest GL 4.3 drivers, each emitting from its own parameters."""
    count = 500
    scene = make_scene(emitters=[emitter(name=f"e{i}", rate=60.0 + i,
                                         position=[i * 0.01, 0.0, 0.5],
                                         particle_class="dust" if i % 2 else "sand")
                                 for i in range(count)], capacity=40000)
    gpu, twin = ParticleSystem(ctx, scene), TwinSystem(scene)
    for frame in frames(3):
        gpu.step(frame)
        twin.step(frame)
    assert gpu.live_count == twin.live_count > count
    np.testing.assert_array_equal(gpu.read_emitters(), twin.emitters)
    records = gpu.read_particles()
    np.testing.assert_array_equal(records["class_id"], twin.particles.class_id)
    np.testing.assert_allclose(records["pos"], twin.particles.pos, rtol=1e-5, atol=1e-4)


def test_new_particles_respect_the_emitter(ctx):
    """Box, cone, speed and lifetime ranges of the newly emitted particles."""
    spec = emitter(rate=30000.0, direction=[0.0, 0.0, 1.0], spread_angle=10.0)
    system = ParticleSystem(ctx, make_scene(emitters=[spec], drag=False, gravity=False,
                                            capacity=1000))
    system.step(frames(1)[0])
    born = system.read_particles()
    assert len(born) == 500
    offset = born["pos"] - np.array(spec["position"])
    assert (np.abs(offset) <= np.array(spec["extent"]) / 2 + 1e-6).all()
    speed = np.linalg.norm(born["vel"], axis=1)
    assert speed.min() >= 2.0 - 1e-5 and speed.max() <= 4.0 + 1e-5
    cos_angle = born["vel"][:, 2] / speed
    assert cos_angle.min() >= np.cos(np.radians(10.0)) - 1e-6
    assert born["lifetime"].min() >= 0.5 and born["lifetime"].max() <= 1.5
    assert len(np.unique(born["pos"][:, 0])) == len(born), "every particle got its own draw"


def test_another_matrix_or_seed_gives_other_particles(ctx):
    scene = make_scene(emitters=[emitter()])
    reseeded = make_scene(emitters=[emitter()], seed=8)

    def positions(scene, matrix_seed):
        system = ParticleSystem(ctx, scene)
        for frame in frames(5, seed=matrix_seed):
            system.step(frame)
        return system.read_particles()["pos"]

    reference = positions(scene, 3)
    np.testing.assert_array_equal(reference, positions(scene, 3))
    for other in (positions(scene, 4), positions(reseeded, 3)):
        assert len(other) == len(reference)
        assert (np.abs(other - reference).max(axis=1) > 1e-3).mean() > 0.99


def test_capacity_overflow_drops_the_same_particles_as_the_twin(ctx):
    scene = make_scene(emitters=[emitter(rate=20000.0), emitter(name="b", rate=7000.0)],
                       capacity=500)
    gpu, twin = ParticleSystem(ctx, scene), TwinSystem(scene)
    for frame in frames(12):
        gpu.step(frame)
        twin.step(frame)
        assert gpu.live_count == twin.live_count
    assert gpu.live_count == 500
    np.testing.assert_array_equal(gpu.read_particles()["age"], twin.particles.age)
    np.testing.assert_allclose(gpu.read_particles()["pos"], twin.particles.pos, atol=1e-4)


def test_reseed_gives_what_a_fresh_system_of_that_seed_gives(ctx):
    wrong = ParticleSystem(ctx, make_scene(emitters=[emitter()], seed=5))
    right = ParticleSystem(ctx, make_scene(emitters=[emitter()], seed=8))
    wrong.reseed(8)
    for frame in frames(10):
        wrong.step(frame)
        right.step(frame)
    assert wrong.checksum() == right.checksum()
