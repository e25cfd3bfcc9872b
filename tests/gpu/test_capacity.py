"""Capacity from the driver: the context's limits, the engine's own bound, and everything
that counts particles (checksum dispatch, frame log, reports) at the largest capacity."""

from __future__ import annotations

import dataclasses

import moderngl
import numpy as np
import pytest
from scenes import make_scene

from cavesim.core.digest.shape import group_count
from cavesim.core.errors import CapacityError
from cavesim.core.frame_cost import NO_COST
from cavesim.core.framelog import FrameLogWriter, read_frame_log
from cavesim.core.limits import MAX_PARTICLES
from cavesim.core.records import PARTICLE_BYTES, PARTICLE_WORDS
from cavesim.core.wire.envelope import decode, encode
from cavesim.core.wire.payloads.from_master import FrameMessage
from cavesim.core.wire.payloads.from_nodes import ReportMessage
from cavesim.gpu.engine import FrameInput, ParticleSystem
from cavesim.gpu.engine.capacity import capacity_limits

GIB = 2**30
GL_MIN_WORK_GROUP_COUNT = 65535  # what GL 4.3 guarantees for each dimension
TWO_GIB = {"GL_MAX_SHADER_STORAGE_BLOCK_SIZE": 2 * GIB,  # what an H100 reports (DESIGN.md)
           "GL_MAX_COMPUTE_WORK_GROUP_COUNT": (2**31 - 1, 65535, 65535),
           "GL_RENDERER": "fake GPU", "GL_VERSION": "4.6.0 fake driver"}


def fake_info(**limits) -> dict:
    """A context's `info` as a driver with 2 GiB storage blocks reports it, changed by `limits`."""
    return {**TWO_GIB, **limits}


def test_a_2_gib_storage_block_allows_53_687_091_particles():
    """2 GiB / 40 bytes; the engine's own bound (a C int of bytes) gives the same count, and
    the driver's limit is named as the binding one."""
    limits = capacity_limits(TWO_GIB)
    assert limits.max_capacity == 2 * GIB // PARTICLE_BYTES == 53_687_091 == MAX_PARTICLES
    assert limits.binding.name == "GL_MAX_SHADER_STORAGE_BLOCK_SIZE"
    limits.check(53_687_091)
    with pytest.raises(CapacityError) as error:
        limits.check(53_687_092)
    message = str(error.value)
    assert "\n" not in message
    for part in ("capacity 53687092", str(53_687_092 * 40),
                 "GL_MAX_SHADER_STORAGE_BLOCK_SIZE = 2147483648 bytes",
                 "at most 53687091 particles", "fake GPU, OpenGL 4.6.0 fake driver"):
        assert part in message


def test_beyond_the_driver_the_engines_addressing_bound_binds():
    limits = capacity_limits(fake_info(GL_MAX_SHADER_STORAGE_BLOCK_SIZE=16 * GIB))
    assert limits.binding.name == "the engine's addressing bound"
    assert limits.max_capacity == MAX_PARTICLES
    with pytest.raises(CapacityError, match="C int"):
        limits.check(MAX_PARTICLES + 1)


def test_a_small_work_group_count_binds_the_checksum_dispatch():
    limits = capacity_limits(fake_info(GL_MAX_SHADER_STORAGE_BLOCK_SIZE=16 * GIB,
                                       GL_MAX_COMPUTE_WORK_GROUP_COUNT=(20000, 1, 1)))
    assert limits.binding.name == "GL_MAX_COMPUTE_WORK_GROUP_COUNT[0]"
    assert limits.max_capacity == 20000 * 64 * 256 // PARTICLE_WORDS
    assert group_count(limits.max_capacity * PARTICLE_WORDS) <= 20000
    with pytest.raises(CapacityError, match=r"GL_MAX_COMPUTE_WORK_GROUP_COUNT\[0\] = 20000"):
        limits.check(limits.max_capacity + 1)


def test_the_checksum_addresses_the_largest_capacity_in_32_bits():
    """checksum/sums.glsl indexes words with a uint and dispatches one group per 16384 words:
    at the engine's bound both fit, and GL's guaranteed group count never binds first."""
    words = MAX_PARTICLES * PARTICLE_WORDS
    assert words <= 2**32 - 1
    assert group_count(words) <= GL_MIN_WORK_GROUP_COUNT
    assert capacity_limits(fake_info(GL_MAX_COMPUTE_WORK_GROUP_COUNT=(
        GL_MIN_WORK_GROUP_COUNT, 1, 1))).max_capacity == MAX_PARTICLES


def test_the_largest_capacity_of_this_context_constructs_and_one_more_fails(ctx):
    limits = capacity_limits(ctx.info)
    largest = limits.max_capacity
    scene = make_scene(drag=False)
    system = ParticleSystem(ctx, dataclasses.replace(scene, capacity=largest))
    system.step(FrameInput(1 / 60, np.eye(3)))
    assert system.capacity == largest and len(system.checksum().digest) == 32
    system.release()
    with pytest.raises(CapacityError) as error:
        ParticleSystem(ctx, dataclasses.replace(scene, capacity=largest + 1))
    message = str(error.value)
    block = ctx.info["GL_MAX_SHADER_STORAGE_BLOCK_SIZE"]
    assert f"GL_MAX_SHADER_STORAGE_BLOCK_SIZE = {block} bytes" in message
    assert f"capacity {largest + 1} needs {(largest + 1) * PARTICLE_BYTES} bytes" in message
    assert f"at most {largest} particles" in message
    assert ctx.info["GL_RENDERER"] in message and "\n" not in message


class _OutOfMemory:
    """The session's context, except that GL reports GL_OUT_OF_MEMORY after any call."""

    def __init__(self, ctx: moderngl.Context) -> None:
        self._ctx = ctx

    def __getattr__(self, name: str):
        return getattr(self._ctx, name)

    @property
    def error(self) -> str:
        return "GL_OUT_OF_MEMORY"


def test_out_of_memory_after_allocating_is_a_capacity_error(ctx):
    with pytest.raises(CapacityError) as error:
        ParticleSystem(_OutOfMemory(ctx), make_scene(drag=False, capacity=1000))
    message = str(error.value)
    assert "GL_OUT_OF_MEMORY" in message and "2 particle buffers of 40000 bytes" in message
    assert ctx.info["GL_RENDERER"] in message


def test_moderngl_passes_a_transform_offset_as_32_bits(ctx):
    """Why the engine's addressing bound is a C int of bytes: moderngl 5.13 parses
    `transform(buffer_offset=)` with "I", so 2**32 + 4 silently writes at byte 4."""
    program = ctx.program(vertex_shader="#version 430\nout uint word;\n"
                                        "void main() { word = 7u; }", varyings=["word"])
    vao = ctx.vertex_array(program, [])
    out = ctx.buffer(bytes(8))
    vao.transform(out, moderngl.POINTS, vertices=1, buffer_offset=2**32 + 4)
    assert np.frombuffer(out.read(), "<u4").tolist() == [0, 7]
    for resource in (vao, program, out):
        resource.release()


def test_frame_log_and_reports_carry_the_largest_count(tmp_path):
    frame = FrameMessage(1, FrameInput(1 / 60, np.eye(3)))
    writer = FrameLogWriter(tmp_path / "frames.log", {"session": "big"})
    writer.append(frame, "ab" * 16, MAX_PARTICLES)
    writer.close()
    _, frames = read_frame_log(tmp_path / "frames.log")
    (logged,) = list(frames)
    assert logged.particles == MAX_PARTICLES == 53_687_091
    report = ReportMessage(1, "front", "ab" * 16, MAX_PARTICLES, 4096, NO_COST)
    assert decode(encode(report, "big"), "big").particles == MAX_PARTICLES
