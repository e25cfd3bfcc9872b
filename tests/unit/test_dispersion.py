"""Turbulent dispersion: the random words every node draws alike, the mixing-length
diffusivity against the surface layer's kappa u* z, the random walk's drift keeping a
well-mixed tracer well mixed, and the twin spreading tracers at sqrt(2 K t)."""

import numpy as np
import pytest

from cavesim.core.air import KARMAN
from cavesim.core.fields.grid import FieldGrid, save_field
from cavesim.core.fields.snapshot_time import START
from cavesim.core.frame import FrameInput
from cavesim.core.random_texture import WORDS_PER_TEXEL, draw_transform, random_words
from cavesim.core.records import PARTICLE_DTYPE
from cavesim.core.scene import parse_scene
from cavesim.core.twin.dispersion import (
    SHEAR_STEP,
    TURBULENCE_FLOOR,
    draw_moments,
    draws,
    mixing_length,
    particle_diffusivity,
    raw_draws,
    seen_turbulence,
    shear_samples,
)
from cavesim.core.twin.system import TwinSystem

SIZE = 64
WORDS = random_words(5, SIZE)
MOMENTS = draw_moments(WORDS)
U_STAR = 0.5
ROUGH, SMOOTH = 0.1, 1e-3  # z0 in m
TRACER = 1e9  # 1/s: a drag rate far above any shear here


def log_law(z0: float):
    """The neutral surface layer: u = (u*/kappa) ln(z/z0) along x."""
    def flow(points: np.ndarray, stage: int = START) -> np.ndarray:
        out = np.zeros_like(points)
        out[:, 0] = U_STAR / KARMAN * np.log(np.maximum(points[:, 2], z0) / z0)
        return out
    return flow


def test_draws_are_the_same_for_the_same_frame_and_unit_uniform():
    rng = np.random.default_rng(1)
    m = draw_transform(rng, SIZE)
    count = WORDS_PER_TEXEL * SIZE * SIZE  # every word once
    xi = draws(WORDS, m, count, MOMENTS)
    np.testing.assert_array_equal(xi, draws(WORDS, m.copy(), count, MOMENTS))
    np.testing.assert_allclose(xi.mean(axis=0), 0.0, atol=1e-7)  # standardised over the words
    np.testing.assert_allclose(xi.var(axis=0), 1.0, rtol=1e-6)
    assert np.abs(xi).max() < 1.01 * np.sqrt(3.0)
    assert len(np.unique(xi, axis=0)) > 0.999 * count, "no word twice within a frame"
    other = draws(WORDS, draw_transform(rng, SIZE), count, MOMENTS)
    assert abs(np.corrcoef(xi[:, 0], other[:, 0])[0, 1]) < 0.01, "frames are independent"
    assert abs(np.corrcoef(xi[:, 0], xi[:, 1])[0, 1]) < 0.01, "components are independent"


def test_a_particles_draw_depends_only_on_its_index_and_the_frame():
    m = draw_transform(np.random.default_rng(2), SIZE)
    np.testing.assert_array_equal(draws(WORDS, m, 100, MOMENTS),
                                  draws(WORDS, m, 1000, MOMENTS)[:100])


def test_the_texture_leaves_its_draws_a_mean_that_the_moments_take_out():
    """A 64² texture's raw draws have a mean of some 1e-3 (one per word and field): enough
    to upset the walk near the ground, where the diffusivity is small."""
    raw = raw_draws(WORDS.reshape(-1))
    mean, scale = MOMENTS
    assert np.abs(raw.mean(axis=0)).max() > 2e-4
    np.testing.assert_allclose(mean, raw.mean(axis=0), rtol=1e-6)
    np.testing.assert_allclose(scale, 1.0 / raw.std(axis=0), rtol=1e-6)


def test_mixing_length_diffusivity_is_kappa_u_star_z_in_the_surface_layer():
    """K = l² |du/dz| with l = kappa z gives the textbook kappa u* z (Monin-Obukhov,
    neutral) over rough ground, where a tenth of the speed stays below u*."""
    z = np.array([0.5, 1.0, 2.0, 4.0])
    p = np.stack([np.zeros_like(z), np.zeros_like(z), z], axis=1)
    k, dk = particle_diffusivity(*shear_samples(log_law(ROUGH), p), z,
                                 np.full(len(z), TRACER), longest=1e9)
    np.testing.assert_allclose(k, KARMAN * U_STAR * z, rtol=5e-3)  # differences over 0.1 m
    np.testing.assert_allclose(dk, KARMAN * U_STAR, rtol=5e-3)


def test_heavy_grains_follow_the_eddies_in_part():
    """A grain relaxing at 1/s where the eddies turn over in 1/|du/dz| = 0.4 s and 1.6 s."""
    z = np.array([0.5, 2.0])
    p = np.stack([np.zeros(2), np.zeros(2), z], axis=1)
    samples = shear_samples(log_law(ROUGH), p)
    tracer, _ = particle_diffusivity(*samples, z, np.full(2, TRACER), 1e9)
    grain, _ = particle_diffusivity(*samples, z, np.full(2, 1.0), 1e9)
    shear = U_STAR / (KARMAN * z)
    np.testing.assert_allclose(grain / tracer, 1.0 / (1.0 + shear), rtol=1e-2)


def test_the_turbulence_does_not_vanish_at_a_jets_velocity_maximum():
    """At the peak of u = 8 (1 - (z - 1)²) the shear is zero, but not K: a tenth of the
    speed times the mixing length (Launder & Rodi's wall jets)."""
    def jet(points, stage=START):
        out = np.zeros_like(points)
        out[:, 0] = 8.0 * (1.0 - (points[:, 2] - 1.0) ** 2)
        return out
    p = np.array([[0.0, 0.0, 1.0]])
    k, _ = particle_diffusivity(*shear_samples(jet, p), np.ones(1), np.full(1, TRACER), 1.5)
    assert k[0] == pytest.approx(mixing_length(np.ones(1), 1.5)[0] * TURBULENCE_FLOOR * 8.0,
                                 rel=0.01)


def test_the_mixing_length_is_capped_by_the_largest_eddies():
    assert mixing_length(np.array([0.0, -1.0]), 2.0).tolist() == [0.0, 0.0]
    assert mixing_length(np.array([1e6]), 2.0)[0] == pytest.approx(2.0, rel=1e-4)


def test_no_time_no_kick():
    assert not seen_turbulence(np.ones(3), np.ones(3), np.ones((3, 3)), 0.0).any()


def test_the_drift_keeps_a_well_mixed_tracer_well_mixed():
    """Tracers spread evenly over 0..2 m in the log layer, reflected at the ground and the
    lid, stay evenly spread while K grows 4-fold with height; without the drift they pile
    up near the ground, where K is small (the well-mixed condition, Thomson 1987)."""
    rng = np.random.default_rng(3)
    n, top, h = 40000, 2.0, 1 / 60
    layers = []
    for drift in (True, False):
        z = rng.uniform(0.0, top, n)
        for _ in range(300):
            p = np.stack([np.zeros(n), np.zeros(n), z], axis=1)
            k, dk = particle_diffusivity(*shear_samples(log_law(SMOOTH), p), z,
                                         np.full(n, TRACER), 1e9)
            xi = rng.uniform(-np.sqrt(3), np.sqrt(3), n)
            z = z + (dk if drift else 0.0) * h + np.sqrt(2 * k * h) * xi
            z = np.abs(z)
            z = np.where(z > top, 2 * top - z, z)
        layers.append(np.histogram(z, bins=4, range=(0.0, top))[0] / (n / 4))
    mixed, unmixed = layers
    assert np.abs(mixed - 1).max() < 0.05, mixed
    assert unmixed[0] > 1.15, unmixed


def couette_scene(tmp_path, shear: float, mixing: float):
    """Fine dust in u = shear (z - 10) along x over a ground plane, with dispersion: still
    at 10 m, so that the shear, not a tenth of the speed, sets the turbulence there."""
    z = np.linspace(0.0, 20.0, 11)
    velocity = np.zeros((11, 2, 2, 3), dtype=np.float32)
    velocity[..., 0] = (shear * (z - 10.0))[:, None, None]
    save_field(tmp_path / "couette.npz", FieldGrid(velocity, (-1e3, -1e3, 0.0), (1e3, 1e3, 20.0)))
    return parse_scene({
        "simulation": {"capacity": 4000, "seed": 9, "integrator": "exponential",
                       "random_texture_size": 64},
        "particle_class": [{"name": "dust", "diameter": 2e-6, "density": 2650.0}],
        "forces": {"drag": {}, "dispersion": {"mixing_length": mixing}},
        "field": {"kind": "file", "file": "couette.npz", "box_min": [-1e3, -1e3, 0.0],
                  "box_max": [1e3, 1e3, 20.0]},
        "collision": {"kind": "plane", "friction": 0.0, "resilience": 1.0},
    }, tmp_path / "couette.toml", "couette")


def test_the_twin_spreads_tracers_at_sqrt_2_k_t(tmp_path):
    """In a uniform shear with a short mixing length K = l² S barely changes with height;
    across the flow (y) the spread of 4000 tracers from one point grows as 2 K t."""
    shear, mixing = 2.0, 0.3
    scene = couette_scene(tmp_path, shear, mixing)
    twin = TwinSystem(scene)
    start = np.zeros(4000, dtype=PARTICLE_DTYPE)
    start["pos"] = (0.0, 0.0, 10.0)
    start["vel"] = (0.0, 0.0, 0.0)
    start["lifetime"] = 1e6
    twin.write_particles(start)
    rng = np.random.default_rng(4)
    seconds = 2.0
    for _ in range(round(seconds * 60)):
        twin.step(FrameInput(1 / 60, draw_transform(rng, 64)))
    k = mixing_length(np.array([10.0]), mixing)[0] ** 2 * shear
    assert twin.particles.pos[:, 1].var() == pytest.approx(2 * k * seconds, rel=0.1)
    assert abs(twin.particles.pos[:, 1].mean()) < 0.1 * np.sqrt(2 * k * seconds)
    assert SHEAR_STEP < 1.0  # the shear is sampled within the grid's cells
