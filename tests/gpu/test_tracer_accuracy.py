"""Passive tracers on the GPU (Mesa llvmpipe here) in a solid-body vortex given as a 64³
float32 grid, interpolated trilinearly: RK4's tracer form against the rotation in closed
form, 60 steps of 1/60 s. The flow is linear, so trilinear interpolation is exact and what
is left is the method's error (about 1e-9 m) and float32's: the grid's node values and the
GPU's arithmetic (measured against the time the float32 steps reach: 6.5e-9 m RMS on the
GPU, RK45 3.0e-8 m, 1.6e-8 m for the float64 twin on the same float32 grid, 1.7e-8 m
between GPU and twin). What only this test proves: the GPU's tracer
branch, through the particle pass, has that accuracy; and RK45's, at one substep a frame."""

from __future__ import annotations

import copy

import numpy as np
import pytest
from scenes import scene_dict

from cavesim.core.fields.grid import save_field
from cavesim.core.position import extended_position
from cavesim.core.records import PARTICLE_DTYPE
from cavesim.core.scene import parse_scene
from cavesim.core.twin.system import TwinSystem
from cavesim.gpu.engine import FrameInput, ParticleSystem
from cavesim.tools.numerics.solid_body import BOX, disk, rotated, solid_body, solid_body_grid

NODES = 64
DT, STEPS = 1 / 60, 60
PARTICLES = 2000
GPU_RMS_LIMIT = 2e-7  # m, RK4 on the GPU after 1 s
TWIN_RMS_LIMIT = 1e-7  # m: the float32 grid's rounding, the method's error 1e-9
IDENTITY = np.eye(3, dtype=np.float32)


@pytest.fixture(scope="module")
def vortex_data(tmp_path_factory) -> dict:
    """Only smoke, a tracer class, carried by the gridded solid-body vortex with RK4."""
    path = tmp_path_factory.mktemp("vortex") / "solid_body.npz"
    save_field(path, solid_body_grid(NODES))
    data = copy.deepcopy(scene_dict(integrator="rk4", capacity=PARTICLES, gravity=False))
    data["particle_class"] = [{"name": "smoke", "diameter": 1e-5, "motion": "tracer"}]
    data["field"] = {"kind": "file", "file": str(path), "box_min": list(BOX[0]),
                     "box_max": list(BOX[1])}
    return data


@pytest.fixture(scope="module")
def vortex_scene(vortex_data):
    return parse_scene(vortex_data, name="solid_body")


def disk_records() -> np.ndarray:
    records = np.zeros(PARTICLES, dtype=PARTICLE_DTYPE)
    records["pos"] = disk(PARTICLES)
    records["lifetime"] = 1e6
    return records


def stepped(system, records: np.ndarray) -> None:
    system.write_particles(records)
    for _ in range(STEPS):
        system.step(FrameInput(DT, IDENTITY))


def rms_against_rotation(start: np.ndarray, end: np.ndarray) -> float:
    """Against the rotation by the time the steps reach: each is dt rounded to float32."""
    exact = rotated(start.astype(np.float64), STEPS * float(np.float32(DT)))
    return float(np.sqrt(np.mean(np.sum((end - exact) ** 2, axis=1))))


def test_rk4_tracers_on_the_gpu_follow_the_gridded_vortex_to_2e_7_m(ctx, vortex_scene):
    start = disk_records()
    gpu = ParticleSystem(ctx, vortex_scene)
    try:
        stepped(gpu, start)
        end = gpu.read_particles()
    finally:
        gpu.release()
    assert len(end) == PARTICLES
    rms = rms_against_rotation(start["pos"], extended_position(end))
    assert rms <= GPU_RMS_LIMIT, f"RMS {rms:.3g} m"
    # the record's velocity is the flow at the new position
    np.testing.assert_allclose(end["vel"], solid_body(end["pos"].astype(np.float64)),
                               atol=2e-7)


def test_adaptive_tracers_on_the_gpu_follow_the_gridded_vortex_in_one_substep_a_frame(
        ctx, vortex_data):
    """RK45 at its default tolerance: Dormand-Prince's error in this flow is far below it,
    so every frame is one substep, and the error is float32's, as RK4's is."""
    data = copy.deepcopy(vortex_data)
    data["simulation"]["tracer_method"] = "rk45"
    start = disk_records()
    gpu = ParticleSystem(ctx, parse_scene(data, name="solid_body"))
    try:
        gpu.write_particles(start)
        for _ in range(STEPS):
            gpu.step(FrameInput(DT, IDENTITY))
            assert gpu.counters() == {"domain_exits": (0,), "tracers_stepped": (PARTICLES,),
                                      "substeps_taken": (PARTICLES,),
                                      "substeps_retaken": (0,), "most_substeps": (1,)}
        end = gpu.read_particles()
    finally:
        gpu.release()
    rms = rms_against_rotation(start["pos"], extended_position(end))
    assert rms <= GPU_RMS_LIMIT, f"RMS {rms:.3g} m"


def test_the_float64_twin_follows_the_gridded_vortex_to_the_grids_rounding(vortex_scene):
    start = disk_records()
    twin = TwinSystem(vortex_scene, np.float64)
    stepped(twin, start)
    rms = rms_against_rotation(start["pos"], twin.particles.position())
    assert rms < TWIN_RMS_LIMIT, f"RMS {rms:.3g} m"
