"""The GPU particle pass against its float64 numpy twin, per integrator and per force."""

import itertools

import numpy as np
import pytest
from scenes import VORTEX_FIELD, make_scene, particle_cloud

from cavesim.engine import FrameInput, ParticleSystem
from cavesim.heightfield import HeightGrid, save_heightfield
from cavesim.scene.model import Integrator
from cavesim.twin import TwinSystem

STEPS = 100
IDENTITY = np.eye(3, dtype=np.float32)
RTOL, ATOL = 1e-5, 1e-4  # float32 state over 100 steps; observed gaps are ~20x smaller
PLANE = {"kind": "plane", "friction": 0.3, "resilience": 0.5, "friction_min_speed": 0.05,
         "height": 0.2}


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


def assert_close(gpu, twin):
    np.testing.assert_allclose(gpu["pos"], twin.pos, rtol=RTOL, atol=ATOL)
    np.testing.assert_allclose(gpu["vel"], twin.vel, rtol=RTOL, atol=ATOL)


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


@pytest.mark.parametrize("features", [
    {"drag": False},
    {"drag": False, "damping": 0.8},
    {"gravity": False},
    {"collision": PLANE},
    {"field": dict(VORTEX_FIELD, out_of_domain="zero")},
    {"field": dict(VORTEX_FIELD, sampling="hardware")},
    {"field": dict(VORTEX_FIELD, kind="uniform", params={"velocity": [2.0, -1.0, 0.5]})},
], ids=["gravity", "gravity+damping", "drag", "ground-plane", "zero-outside", "hw-filter",
        "uniform-flow"])
def test_each_force_matches_its_twin(ctx, features):
    for integrator in ("semi_implicit_euler", "rk4"):
        gpu, twin = run_both(ctx, make_scene(integrator=integrator, **features))
        assert_close(gpu, twin)


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
