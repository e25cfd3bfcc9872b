"""The GPU particle pass against its float64 numpy twin, per integrator and per force."""

import itertools

import moderngl
import numpy as np
import pytest
from scenes import VORTEX_FIELD, make_scene, particle_cloud, scene_dict, with_smoke

from cavesim.core.fields.grid import FieldGrid, build_field, save_field
from cavesim.core.fields.heights import HeightGrid, save_heightfield
from cavesim.core.scene import parse_scene
from cavesim.core.scene.model import FieldSampling, Integrator
from cavesim.core.twin.system import TwinSystem
from cavesim.gpu.engine import FrameInput, ParticleSystem
from cavesim.gpu.gl.filtering import filter_weight_error

STEPS = 100
IDENTITY = np.eye(3, dtype=np.float32)
RTOL, ATOL = 1e-5, 1e-4  # float32 state over 100 steps; observed gaps are ~20x smaller
PLANE = {"kind": "plane", "friction": 0.3, "resilience": 0.5, "friction_min_speed": 0.05,
         "height": 0.2}
pytestmark = pytest.mark.xdist_group("engine_vs_twin")  # one run per integrator, on one worker


def run_both(ctx, scene, steps=STEPS, dt=1 / 60):
    """Final GPU state and twin state after `steps` frames from the same particle cloud."""
    gpu, twin = ParticleSystem(ctx, scene), TwinSystem(scene)
    cloud = particle_cloud(400)
    gpu.write_particles(cloud)
    twin.write_particles(cloud)
    for _ in range(steps):
        frame = FrameInput(dt, IDENTITY)
        gpu.step(frame)
        twin.step(frame)
    return gpu.read_particles(), twin.particles


def assert_close(gpu, twin, atol=ATOL):
    np.testing.assert_allclose(gpu["pos"], twin.pos, rtol=RTOL, atol=atol)
    np.testing.assert_allclose(gpu["vel"], twin.vel, rtol=RTOL, atol=atol)


def hardware_filter_atol(ctx, scene, steps=STEPS, dt=1 / 60) -> float:
    """ATOL plus what this context's hardware filter may add against the twin's exact
    trilinear: each of the three nested lerps misses by at most the measured weight error
    times the largest jump between neighbouring nodes, and drag pulls a particle toward
    that flow, so its velocity error stays below the flow's and its position error below
    that times the run's length. Exact weights (llvmpipe) leave ATOL as it is; 8-bit
    weights (NVIDIA: 1.3e-3 m seen in this test) get a bound of about 1.5e-2."""
    velocity = build_field(scene.field).velocity
    jump = max(np.abs(np.diff(velocity, axis=axis)).max() for axis in range(3))
    return ATOL + 3 * filter_weight_error(ctx) * jump * steps * dt


@pytest.fixture(scope="module")
def per_integrator(gl_session):
    """GPU and twin end states of the drag + gravity + damping scene for every integrator."""
    return {integrator: run_both(gl_session, make_scene(integrator=integrator.value,
                                                        damping=0.3))
            for integrator in Integrator}


@pytest.mark.parametrize("integrator", list(Integrator), ids=lambda i: i.value)
def test_each_integrator_matches_its_twin(per_integrator, integrator):
    gpu, twin = per_integrator[integrator]
    assert np.isfinite(gpu["pos"]).all()
    assert_close(gpu, twin)


def test_the_tolerance_tells_integrators_apart(per_integrator):
    """Had the GPU run another method, the comparison above would have failed."""
    for a, b in itertools.combinations(Integrator, 2):
        gpu_a, _ = per_integrator[a]
        _, twin_b = per_integrator[b]
        assert not np.allclose(gpu_a["pos"], twin_b.pos, rtol=RTOL, atol=ATOL), (
            f"{a.value} on the GPU passes as the twin of {b.value}")


@pytest.mark.parametrize("integrator", list(Integrator), ids=lambda i: i.value)
def test_tracers_beside_inertial_particles_match_their_twin(ctx, integrator):
    """Half the cloud smoke, stepped by the integrator's tracer method: the GPU's branch
    per particle against the twin's tracer steps."""
    scene = parse_scene(with_smoke(scene_dict(integrator=integrator.value, damping=0.3)),
                        name="tracers")
    gpu, twin = run_both(ctx, scene)
    assert np.isfinite(gpu["pos"]).all() and (twin.class_id == 1).sum() > 150
    assert_close(gpu, twin)


@pytest.mark.parametrize("features", [
    {"drag": False},
    {"drag": False, "damping": 0.8},
    {"gravity": False},
    # grains come to rest on it: without a rebound, each step presses them into it, where
    # with one float32 and float64 may disagree on whether a step ends below the ground
    {"collision": dict(PLANE, resilience=0.0)},
    {"field": dict(VORTEX_FIELD, out_of_domain="zero")},
    {"field": dict(VORTEX_FIELD, sampling="hardware")},
    {"field": dict(VORTEX_FIELD, kind="uniform", params={"velocity": [2.0, -1.0, 0.5]})},
    {"field": dict(VORTEX_FIELD, interpolation="catmull_rom")},
    {"field": dict(VORTEX_FIELD, interpolation="bspline", out_of_domain="zero")},
], ids=["gravity", "gravity+damping", "drag", "ground-plane", "zero-outside", "hw-filter",
        "uniform-flow", "catmull-rom", "bspline-zero-outside"])
def test_each_force_matches_its_twin(ctx, features):
    for integrator in ("semi_implicit_euler", "rk4"):
        scene = make_scene(integrator=integrator, **features)
        gpu, twin = run_both(ctx, scene)
        hardware = scene.field is not None and scene.field.sampling is FieldSampling.HARDWARE
        assert_close(gpu, twin, hardware_filter_atol(ctx, scene) if hardware else ATOL)


def test_dispersion_matches_its_twin(ctx, tmp_path):
    """The random walk in a shear u = (2 z, 0, 0.3 z) over a plane: the same draws, the
    same diffusivity. Without gravity, away from the ground (a grain resting on it bounces
    or not by a rounding, and the walk's kicks would make that common). The tolerance is
    ten times ATOL: the shear, from flow samples 0.1 m apart, cancels about u / (0.1 du/dz)
    = 50 times float32's rounding of u, and the kicks are 15 m/s."""
    z = np.linspace(-1.0, 11.0, 13)
    velocity = np.zeros((13, 2, 2, 3), dtype=np.float32)
    velocity[..., 0] = (2.0 * z)[:, None, None]
    velocity[..., 2] = (0.3 * z)[:, None, None]
    save_field(tmp_path / "shear.npz", FieldGrid(velocity, (-50, -50, -1.0), (50, 50, 11.0)))
    field = {"kind": "file", "file": str(tmp_path / "shear.npz"),
             "box_min": [-50, -50, -1.0], "box_max": [50, 50, 11.0]}
    walks = {}
    for mixing in (None, {"mixing_length": 1.0}):
        for integrator in ("semi_implicit_euler", "rk4", "exponential"):
            scene = make_scene(integrator=integrator, gravity=False, field=field,
                               collision=dict(PLANE, height=-1.0), dispersion=mixing)
            gpu, twin = run_both(ctx, scene)
            assert_close(gpu, twin, 10 * ATOL)
            walks[integrator, mixing is not None] = gpu["pos"]
    spread = np.abs(walks["rk4", True] - walks["rk4", False]).mean()
    assert spread > 100 * ATOL, "the walk moved the particles"


def test_the_tolerance_tells_interpolations_apart(ctx):
    """Had the GPU sampled the grid trilinearly, the cubic cases above would have failed."""
    states = {}
    for interpolation in ("trilinear", "catmull_rom", "bspline"):
        scene = make_scene(integrator="rk4", field=dict(VORTEX_FIELD, interpolation=interpolation))
        states[interpolation] = run_both(ctx, scene)
    for a, b in itertools.permutations(states, 2):
        gpu_a, _ = states[a]
        _, twin_b = states[b]
        assert not np.allclose(gpu_a["pos"], twin_b.pos, rtol=RTOL, atol=ATOL), (a, b)


def test_the_filter_weight_error_is_measured_on_this_context(ctx):
    # exact float weights on llvmpipe; 8-bit weights miss by at most 1/512 when rounded
    assert 0.0 <= filter_weight_error(ctx) < 1 / 256


def test_the_hardware_filter_bound_still_catches_nearest_sampling(ctx):
    """Had the texture unit sampled the nearest node instead, the bound would not hold."""
    scene = make_scene(integrator="rk4", field=dict(VORTEX_FIELD, sampling="hardware"))
    gpu = ParticleSystem(ctx, scene)
    gpu.resources["flow_field"].filter = (moderngl.NEAREST, moderngl.NEAREST)
    twin = TwinSystem(scene)
    for system in (gpu, twin):
        system.write_particles(particle_cloud(400))
    for _ in range(STEPS):
        gpu.step(FrameInput(1 / 60, IDENTITY))
        twin.step(FrameInput(1 / 60, IDENTITY))
    with pytest.raises(AssertionError):
        assert_close(gpu.read_particles(), twin.particles, hardware_filter_atol(ctx, scene))


def test_heightfield_collision_matches_its_twin(ctx, tmp_path):
    x = np.linspace(-4, 4, 33)
    y = np.linspace(-4, 4, 25)
    height = 0.3 + 0.15 * np.sin(x)[None, :] * np.cos(0.7 * y)[:, None] + 0.05 * x[None, :]
    save_heightfield(tmp_path / "terrain.npz",
                     HeightGrid(height.astype(np.float32), (-4.0, -4.0), (4.0, 4.0)))
    collision = {"kind": "heightfield", "friction": 0.2, "resilience": 0.6,
                 "file": str(tmp_path / "terrain.npz")}
    gpu, twin = run_both(ctx, make_scene(collision=collision))
    assert_close(gpu, twin)
    assert (gpu["pos"][:, 2] < 0.7).mean() > 0.4, "the test needs particles on the ground"


def test_ground_keeps_particles_above_it(ctx):
    gpu, _ = run_both(ctx, make_scene(collision=PLANE, drag=False))
    assert gpu["pos"][:, 2].min() >= 0.2
