"""The Coriolis acceleration ([forces] coriolis): a particle in a turning frame against its
closed form, the GPU against the float64 twin on both engine paths, and in portable
arithmetic the GPU's bits against the portable twin's."""

import numpy as np
import pytest
from scenes import particle_cloud, scene_dict

from cavesim.core.errors import SceneError
from cavesim.core.records import PARTICLE_DTYPE
from cavesim.core.scene import parse_scene
from cavesim.core.twin.system import TwinSystem
from cavesim.gpu.engine import FrameInput, ParticleSystem

IDENTITY = np.eye(3, dtype=np.float32)
OMEGA = 0.5  # rad/s about z: an inertial circle of period pi / OMEGA = 6.3 s
SPEED = 2.0  # m/s


def turning_scene(integrator="rk4", engine="gs_tf", arithmetic="native", drag=False):
    data = scene_dict(integrator=integrator, drag=drag, gravity=False, engine=engine,
                      arithmetic=arithmetic)
    data["forces"]["coriolis"] = [0.0, 0.0, OMEGA]
    return parse_scene(data, name="turning")


def one_particle() -> np.ndarray:
    record = np.zeros(1, dtype=PARTICLE_DTYPE)
    record["pos"] = (0.0, 0.0, 1.0)
    record["vel"] = (SPEED, 0.0, 0.0)
    record["lifetime"] = 1e6
    return record


def test_a_particle_in_a_turning_frame_runs_the_inertial_circle():
    """dv/dt = -2 Omega x v: v turns clockwise (Omega up) at 2 Omega, on a circle of radius
    |v| / (2 Omega) about (0, -|v| / (2 Omega)); RK4 holds it to its order, and the circle's
    turning is the feature's (without it the particle goes straight)."""
    steps, dt = 120, 1 / 60
    twin = TwinSystem(turning_scene())
    twin.write_particles(one_particle())
    for _ in range(steps):
        twin.step(FrameInput(dt, IDENTITY))
    t, radius = steps * float(np.float32(dt)), SPEED / (2 * OMEGA)  # the frames' float32 dt
    angle = 2 * OMEGA * t
    expected = (radius * np.sin(angle), -radius * (1 - np.cos(angle)), 1.0)
    np.testing.assert_allclose(twin.particles.position()[0], expected, atol=1e-8)
    np.testing.assert_allclose(twin.particles.vel[0],
                               (SPEED * np.cos(angle), -SPEED * np.sin(angle), 0.0), atol=1e-8)
    assert np.linalg.norm(twin.particles.position()[0] - (SPEED * t, 0.0, 1.0)) > 0.5


def stepped(ctx, scene, frames: int):
    """The GPU's particles and the twin's after `frames` frames from one cloud."""
    gpu, twin = ParticleSystem(ctx, scene), TwinSystem(scene)
    cloud = particle_cloud(300)
    gpu.write_particles(cloud)
    twin.write_particles(cloud)
    for _ in range(frames):
        frame = FrameInput(1 / 60, IDENTITY)
        gpu.step(frame)
        twin.step(frame)
    return gpu.read_particles(), twin.particles


@pytest.mark.parametrize("engine", ["gs_tf", "compute"])
@pytest.mark.parametrize("integrator", ["rk4", "etd2rk", "semi_implicit_euler"])
def test_the_gpu_turns_as_its_twin(ctx, engine, integrator):
    got, twin = stepped(ctx, turning_scene(integrator, engine, drag=True), 60)
    np.testing.assert_allclose(got["pos"], twin.pos, rtol=1e-5, atol=1e-4)
    np.testing.assert_allclose(got["vel"], twin.vel, rtol=1e-5, atol=1e-4)
    still = TwinSystem(parse_scene(scene_dict(integrator=integrator, gravity=False),
                                   name="still"))
    still.write_particles(particle_cloud(300))
    for _ in range(60):
        still.step(FrameInput(1 / 60, IDENTITY))
    assert not np.allclose(got["vel"], still.particles.vel, rtol=1e-5, atol=1e-4)


@pytest.mark.parametrize("engine", ["gs_tf", "compute"])
def test_in_portable_arithmetic_the_gpu_holds_the_portable_twins_bits(ctx, engine):
    got, twin = stepped(ctx, turning_scene("etd2rk", engine, "portable", drag=True), 30)
    assert got.tobytes() == twin.records().tobytes()


def test_the_rotation_must_be_three_finite_numbers():
    data = scene_dict()
    data["forces"]["coriolis"] = [0.0, 7.3e-5]
    with pytest.raises(SceneError, match="forces.coriolis"):
        parse_scene(data, name="bad")
