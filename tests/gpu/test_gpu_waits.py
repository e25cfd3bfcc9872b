"""Waiting for the GPU: a polled fence with a limit, the frame's few waits, and the GPU
timers of its passes (sampled)."""

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from cavesim.core.errors import ContextError
from cavesim.core.frame import FrameInput
from cavesim.core.scene import load_scene
from cavesim.core.scene.model import Engine
from cavesim.gpu.engine import ParticleSystem
from cavesim.gpu.engine.pass_timers import GPU_PASSES
from cavesim.gpu.gl import fence as fence_module
from cavesim.gpu.gl.fence import GL_TIMEOUT_EXPIRED, GpuFence

MINIMAL = Path(__file__).parents[2] / "config" / "scenes" / "minimal.toml"
FRAME = FrameInput(np.float32(1 / 60), np.eye(3, dtype=np.float32))


def counted_waits(system: ParticleSystem) -> list[int]:
    """A list that grows by one on each of the system's fence waits."""
    waits: list[int] = []
    wait = system.fence.wait

    def counting() -> None:
        waits.append(1)
        wait()

    system.fence.wait = counting
    return waits


@pytest.mark.parametrize(("engine", "waits"), [(Engine.COMPUTE, 1), (Engine.GS_TF, 3)])
def test_a_frame_waits_for_the_gpu_once_on_compute_and_per_count_on_gs_tf(ctx, engine, waits):
    """compute: only the checksum's read; GS/TF also reads the survivors' count (the
    emission's offset) and the emitted count, each after its own fence."""
    system = ParticleSystem(ctx, dataclasses.replace(load_scene(MINIMAL), engine=engine))
    for _ in range(3):  # emitters going
        system.step(FRAME)
        system.checksum()
    counted = counted_waits(system)
    system.step(FRAME)
    system.checksum()
    assert len(counted) == waits and system.fence.take_waited() > 0


def test_a_gpu_that_never_finishes_ends_the_wait_at_its_limit(ctx, monkeypatch):
    fence = GpuFence(ctx)
    fence._client_wait_sync = lambda sync, flags, timeout: GL_TIMEOUT_EXPIRED
    monkeypatch.setattr(fence_module, "WAIT_LIMIT_SECONDS", 0.05)
    with pytest.raises(ContextError, match="the GPU did not finish a frame's work within "
                                           "0.05 s"):
        fence.wait()
    assert fence.take_waited() >= 0.05 and fence.take_waited() == 0.0


def test_only_an_armed_frame_is_timed_on_the_gpu(ctx):
    system = ParticleSystem(ctx, load_scene(MINIMAL))
    for _ in range(3):
        system.step(FRAME)
        system.checksum()
    assert system.timers.read_us() is None  # nothing armed, nothing timed
    system.timers.armed = True
    system.step(FRAME)
    system.checksum()
    times = system.timers.read_us()
    assert set(times) == set(GPU_PASSES) and times["particle_pass"] > 0
    assert times["checksum_pass"] > 0 and system.timers.read_us() is None  # read once
