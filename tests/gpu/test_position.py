"""The position's low part (cavesim/core/position.py, shaders/include/position.glsl): exact
sums, the record's byte, and on the GPU a steady motion that no longer loses a rounding a step.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
from scenes import make_scene

from cavesim.core.position import (
    extended_position,
    low_code,
    low_part,
    move,
    split_position,
    two_sum,
)
from cavesim.core.records import PARTICLE_DTYPE
from cavesim.gpu.engine import FrameInput, ParticleSystem

RNG = np.random.default_rng(16)
IDENTITY = np.eye(3, dtype=np.float32)  # no emitters: the random texture is never read


def floats(count: int, scale: float) -> np.ndarray:
    return (RNG.standard_normal((count, 3)) * scale).astype(np.float32)


def spacing(hi: np.ndarray) -> np.ndarray:
    """float64 distance from |hi| to the next float32 away from zero."""
    magnitude = np.abs(hi).astype(np.float32)
    return (np.nextafter(magnitude, np.float32(np.inf)) - magnitude).astype(np.float64)


def test_two_sum_is_exact():
    a, b = floats(2000, 10.0), floats(2000, 1e-3)
    s, e = two_sum(a, b)
    for x, y, sx, ex in zip(a.ravel()[:300], b.ravel()[:300], s.ravel(), e.ravel(), strict=False):
        assert Fraction(float(x)) + Fraction(float(y)) == Fraction(float(sx)) + Fraction(float(ex))
    assert np.all(np.abs(e.astype(np.float64)) <= spacing(s) / 2)


def test_the_record_keeps_the_low_part_to_a_512th_of_a_spacing():
    """Half a code, save where low rounds to 128 codes (half a spacing), kept as 127."""
    position = RNG.uniform(-50, 50, (5000, 3))
    records = np.zeros(len(position), PARTICLE_DTYPE)
    records["pos"], records["pos_low"] = split_position(position)
    error = np.abs(extended_position(records) - position) / spacing(records["pos"])
    clamped = records["pos_low"] == 127
    assert np.all(error[~clamped] <= (1 + 1e-6) / 512) and np.all(error <= (1 + 1e-6) / 256)
    assert 0 < clamped.mean() < 0.01
    # the codes' whole range is used, and a code of a zero or tiny hi is 0
    assert records["pos_low"].min() == -128 and records["pos_low"].max() == 127
    tiny = np.array([[0.0, 1e-30, -1e-35]], np.float32)
    assert np.all(low_code(tiny, np.full((1, 3), 1e-38, np.float32)) == 0)
    assert np.all(low_part(tiny, np.full((1, 3), 5, np.int8)) == 0)


def test_a_move_keeps_the_sum_exact_until_the_record_rounds_it():
    hi, dp = floats(3000, 20.0), floats(3000, 1e-2)
    low = low_part(hi, RNG.integers(-128, 128, hi.shape).astype(np.int8))
    new_hi, new_low = move(hi, low, dp)
    exact = hi.astype(np.float64) + low + dp  # float64 holds these sums exactly here
    assert np.array_equal(new_hi.astype(np.float64) + new_low, exact)
    assert np.all(np.abs(new_low.astype(np.float64)) <= spacing(new_hi) / 2)


def test_a_steady_motion_on_the_gpu_ends_where_the_exact_sum_of_its_increments_does(ctx):
    """No forces, 960 steps of 1/960 s: each step adds the same float32 increment h v. A
    float32 position alone rounds it the same way every step and ends up to 480 spacings
    off; hi + low rounds it to a 256th of a spacing each step: half a 256th off, or a whole
    one where low lies within half a 256th of half a spacing and its byte's 128 is kept as
    127, so at most 960 / 256 spacings. Its own generator: the particles do not depend on
    which tests of the module ran before on the same worker."""
    rng = np.random.default_rng(16)
    scene = make_scene(integrator="explicit_euler", drag=False, gravity=False, capacity=64)
    records = np.zeros(64, PARTICLE_DTYPE)
    records["pos"] = rng.uniform(2, 9, (64, 3))
    records["vel"] = rng.uniform(-0.7, 0.7, (64, 3))
    records["lifetime"] = 1e6
    gpu = ParticleSystem(ctx, scene)
    gpu.write_particles(records)
    h, steps = np.float32(1 / 960), 960
    for _ in range(steps):
        gpu.step(FrameInput(float(h), IDENTITY))
    increment = (h * records["vel"]).astype(np.float64)  # f_mul(h, v): the same every step
    exact = records["pos"].astype(np.float64) + steps * increment
    end = gpu.read_particles()
    widest = spacing(np.maximum(np.abs(records["pos"]), np.abs(end["pos"])))  # on the way
    kept = np.abs(extended_position(end) - exact) / widest
    assert kept.max() <= steps / 256, kept.max()
    float32_alone = records["pos"].copy()
    for _ in range(steps):
        float32_alone = float32_alone + (h * records["vel"])
    error_alone = np.abs(float32_alone - exact) / widest
    assert error_alone.max() > 100 and error_alone.mean() > 50 * kept.mean()


@pytest.mark.parametrize("engine", ["gs_tf", "compute"])
def test_both_engine_paths_pass_the_low_part_through_a_frame_unchanged(ctx, engine):
    scene = make_scene(drag=False, gravity=False, capacity=64, engine=engine)
    records = np.zeros(64, PARTICLE_DTYPE)
    records["pos"] = RNG.uniform(-9, 9, (64, 3))
    records["pos_low"] = RNG.integers(-127, 128, (64, 3))  # -128: a tie, which moves hi
    records["lifetime"] = 1e6
    records["class_id"] = np.arange(64) % 2
    gpu = ParticleSystem(ctx, scene)
    gpu.write_particles(records)
    gpu.step(FrameInput(1 / 60, IDENTITY))  # no velocity, no force: nothing moves
    end = gpu.read_particles()
    for field in ("pos", "pos_low", "vel", "class_id"):
        np.testing.assert_array_equal(end[field], records[field])
