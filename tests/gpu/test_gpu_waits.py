"""Waiting for the GPU: a polled fence with a limit, the frame's few waits, and the GPU
timers of its passes (sampled)."""

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from cavesim.core.digest.shape import StateChecksum
from cavesim.core.errors import ContextError
from cavesim.core.frame import FrameInput
from cavesim.core.scene import load_scene
from cavesim.core.scene.model import Engine
from cavesim.gpu.engine import ParticleSystem
from cavesim.gpu.engine.pass_timers import GPU_PASSES
from cavesim.gpu.gl import fence as fence_module
from cavesim.gpu.gl import primitive_counts
from cavesim.gpu.gl.fence import GL_TIMEOUT_EXPIRED, GpuFence
from cavesim.gpu.gl.primitive_counts import query_buffers_offered

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


@pytest.mark.parametrize("engine", [Engine.COMPUTE, Engine.GS_TF])
def test_a_frame_waits_for_the_gpu_once(ctx, engine):
    """Only the checksum's read waits: the GS/TF passes' counts land on the GPU, where this
    context has query buffer objects; the dropped count is read after that wait."""
    assert query_buffers_offered(ctx.version_code, ctx.extensions)
    waits, _ = waits_of_a_frame(ctx, engine)
    assert waits == 1


def test_without_query_buffers_gs_tf_waits_once_more_per_count(ctx, monkeypatch):
    """A context without query buffer objects: the host reads the survivors' and the emitted
    counts, each after its own wait, and the frame's bytes stay the same."""
    _, on_gpu = waits_of_a_frame(ctx, Engine.GS_TF)
    monkeypatch.setattr(primitive_counts, "QUERY_BUFFER_VERSION", 10_000)
    monkeypatch.setattr(primitive_counts, "QUERY_BUFFER_EXTENSION", "GL_none")
    waits, by_host = waits_of_a_frame(ctx, Engine.GS_TF)
    assert waits == 3 and by_host == on_gpu and on_gpu.particles > 0


def waits_of_a_frame(ctx, engine: Engine) -> tuple[int, StateChecksum]:
    """The fence waits of a steady frame and its checksum (emitters going), and the
    checksum."""
    system = ParticleSystem(ctx, dataclasses.replace(load_scene(MINIMAL), engine=engine))
    for _ in range(3):
        system.step(FRAME)
        system.checksum()
    counted = counted_waits(system)
    system.step(FRAME)
    state = system.checksum()
    assert system.dropped() == 0
    assert system.fence.take_waited() > 0
    system.release()
    return len(counted), state


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
