"""A scene far from the world's origin keeps the float32 floor of one at it: `[simulation]
origin` takes the scene's own origin from every coordinate it holds
(cavesim.core.scene.origin), so the GPU steps the same bytes as for the scene at 0. A flow
file's grid moves with it (tests/unit/test_scene_flow_files.py holds the twins to it)."""

import copy
import dataclasses

import numpy as np
import pytest
from far_fields import FORMATS, expected_positions, far_scene, tracers, write_far_field
from scenes import FOUNTAIN, scene_dict

from cavesim.core.digest.twin import reference_checksum
from cavesim.core.fields.heights import HeightGrid, load_heightfield, save_heightfield
from cavesim.core.frame import FrameInput
from cavesim.core.records import PARTICLE_DTYPE
from cavesim.core.scene import parse_scene
from cavesim.core.scene.model import ENGINE_PATHS
from cavesim.core.twin.kernels import PORTABLE
from cavesim.core.twin.system import TwinSystem
from cavesim.gpu.engine import ParticleSystem

OUT = (5000.0, -3000.0, 100.0)  # m: where the scene lies in the world
FLOOR = 5e-6  # m: the float32 floor required at 1/960 s
IDENTITY = np.eye(3, dtype=np.float32)


def world(data: dict, offset) -> dict:
    """The scene dict moved by `offset` in the world: its field box and vortex centre, its
    emitters and its ground."""
    moved = copy.deepcopy(data)
    field = moved["field"]
    for key in ("box_min", "box_max"):
        field[key] = [c + o for c, o in zip(field[key], offset, strict=True)]
    field["params"]["center"] = [c + o for c, o in zip(field["params"]["center"], offset,
                                                        strict=False)]
    for emitter in moved["emitter"]:
        emitter["position"] = [c + o for c, o in zip(emitter["position"], offset, strict=True)]
    if "collision" in moved:
        moved["collision"]["height"] = moved["collision"].get("height", 0.0) + offset[2]
    return moved


def at_zero() -> dict:
    """A vortex, a fountain and a ground, their coordinates such that moving them 5 km and
    back is exact in float64."""
    data = scene_dict("etd2rk", emitters=[FOUNTAIN], capacity=3000,
                      collision={"kind": "plane", "friction": 0.3, "resilience": 0.3})
    data["field"]["params"]["center"] = [0.25, -0.125]
    return data


def test_the_loader_takes_the_origin_from_every_coordinate():
    far = world(at_zero(), OUT)
    far["simulation"]["origin"] = list(OUT)
    here, there = parse_scene(at_zero(), name="s"), parse_scene(far, name="s")
    assert there.origin == OUT
    assert (there.field, there.emitters, there.collision) == (here.field, here.emitters,
                                                               here.collision)


def test_a_height_field_is_read_relative_to_the_origin(tmp_path):
    grid = HeightGrid(np.array([[1.0, 2.0], [3.0, 4.0]], np.float32), (4990.0, -3010.0),
                      (5010.0, -2990.0))
    save_heightfield(tmp_path / "ground.npz", grid)
    local = load_heightfield(tmp_path / "ground.npz", OUT)
    assert (local.box_min, local.box_max) == ((-10.0, -10.0), (10.0, 10.0))
    np.testing.assert_array_equal(local.height, grid.height - np.float32(100.0))


def test_far_out_with_its_origin_the_gpu_steps_the_bytes_of_the_scene_at_zero(ctx):
    far = world(at_zero(), OUT)
    far["simulation"]["origin"] = list(OUT)
    systems = [ParticleSystem(ctx, parse_scene(data, name="s")) for data in (at_zero(), far)]
    for _ in range(120):
        for system in systems:
            system.step(FrameInput(np.float32(1 / 60), IDENTITY))
    here, there = (system.checksum() for system in systems)
    assert here == there and here.particles > 500
    for system in systems:
        system.release()


@pytest.mark.parametrize(("origin", "within_floor"), [(OUT, True), ((0.0, 0.0, 0.0), False)])
def test_particles_5_km_out_keep_the_float32_floor_only_with_the_origin(ctx, origin,
                                                                         within_floor):
    """RMS |GPU - float64 twin| after 1 s at 1/960 s of 500 particles in the vortex 5 km
    out: within 5e-6 m with the scene's origin there, well beyond it without."""
    data = world(scene_dict("etd2rk", capacity=500), OUT)
    data["simulation"]["origin"] = list(origin)
    scene = parse_scene(data, name="far")
    rng = np.random.default_rng(3)
    start = np.zeros(500, PARTICLE_DTYPE)
    start["pos"] = rng.uniform((-3, -3, 0.5), (3, 3, 3.5), (500, 3)) + np.subtract(OUT, origin)
    start["vel"] = rng.normal(0.0, 1.0, (500, 3))
    start["lifetime"] = 1e6
    gpu, twin = ParticleSystem(ctx, scene), TwinSystem(scene, np.float64)
    for system in (gpu, twin):
        system.write_particles(start)
    for _ in range(960):
        frame = FrameInput(np.float32(1 / 960), IDENTITY)
        gpu.step(frame)
        twin.step(frame)
    moved = gpu.read_particles()["pos"].astype(np.float64)
    floor = float(np.sqrt(np.mean(np.sum((moved - twin.particles.pos) ** 2, axis=1))))
    gpu.release()
    assert (floor <= FLOOR) is within_floor, floor


FILE_FRAMES, FILE_DT = 60, np.float32(1 / 60)


@pytest.mark.parametrize("engine", ENGINE_PATHS)
@pytest.mark.parametrize("suffix", FORMATS)
def test_a_flow_file_5_km_out_carries_tracers_where_it_lies_on_both_paths(ctx, tmp_path,
                                                                          suffix, engine):
    """A .nc, .vti or .npz grid in world coordinates, the scene's origin at its centre: the
    tracers move in its flow at their place (2 m/s at the centre), not still."""
    data = far_scene(write_far_field(tmp_path, suffix), engine=engine.value)
    gpu = ParticleSystem(ctx, parse_scene(data, name="far"))
    start = tracers(64)
    gpu.write_particles(start)
    for _ in range(FILE_FRAMES):
        gpu.step(FrameInput(FILE_DT, IDENTITY))
    moved = gpu.read_particles()["pos"].astype(np.float64)
    gpu.release()
    np.testing.assert_allclose(moved, expected_positions(start["pos"],
                                                         FILE_FRAMES * float(FILE_DT)),
                               rtol=0, atol=1e-5)


@pytest.mark.parametrize("suffix", FORMATS)
def test_a_flow_file_5_km_out_in_portable_arithmetic_gives_the_twins_bits(ctx, tmp_path,
                                                                          suffix):
    """Both engine paths step the portable twin's bits every frame, and the twin's tracers
    end where the file's flow carries them."""
    scene = parse_scene(far_scene(write_far_field(tmp_path, suffix), arithmetic="portable"),
                        name="far")
    twin = TwinSystem(scene)
    assert twin.kernels is PORTABLE
    gpus = {engine: ParticleSystem(ctx, dataclasses.replace(scene, engine=engine))
            for engine in ENGINE_PATHS}
    start = tracers(64)
    for system in (twin, *gpus.values()):
        system.write_particles(start)
    for frame in range(1, FILE_FRAMES + 1):
        inputs = FrameInput(FILE_DT, IDENTITY)
        twin.step(inputs)
        expected = reference_checksum(twin.particles.records().view(np.uint32),
                                      twin.emitters.view(np.uint32), scene.seed)
        for engine, gpu in gpus.items():
            gpu.step(inputs)
            assert gpu.checksum() == expected, f"frame {frame}, {engine.value} path"
    for gpu in gpus.values():
        gpu.release()
    np.testing.assert_allclose(twin.particles.pos, expected_positions(
        start["pos"], FILE_FRAMES * float(FILE_DT)), rtol=0, atol=1e-5)
