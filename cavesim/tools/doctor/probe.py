"""One EGL device examined in a child process of its own: `python -m cavesim.tools.doctor.probe N`.

A child per device, because a process holds one GL context (a second one takes over the
first one's calls), and because a broken driver may crash or hang while opening one: the
doctor must still reach its verdict, so the child has a deadline. The child opens the
context the engine opens (GL 4.3 core: a driver gives what is asked, so the limits read
are the engine's), checks what the engine needs and runs the engine's checksum programs
once against numpy. Every fix it gives fits the device's vendor (`vendors.py`).
"""

from __future__ import annotations

import json
import subprocess
import sys
from collections.abc import Callable

import moderngl
import numpy as np

from cavesim.core.digest.shape import WORKGROUP_SIZE
from cavesim.core.digest.twin import reference_checksum
from cavesim.core.emitters import EMIT_BATCH
from cavesim.core.errors import ContextError, ShaderError
from cavesim.core.records import EMITTER_WORDS, PARTICLE_BYTES, PARTICLE_WORDS
from cavesim.gpu.engine.capacity import capacity_limits
from cavesim.gpu.engine.checksum import GpuChecksum
from cavesim.gpu.gl.context import create_context, describe
from cavesim.gpu.gl.driver import Driver
from cavesim.gpu.gl.fence import GpuFence
from cavesim.gpu.gl.vendors import vendor_of

PROBE_TIMEOUT = 60.0  # s for one device: open a context, compile, run the checksum once
SMOKE_PARTICLES, SMOKE_EMITTERS = 4_000, 3  # three sums work groups, a partial one, emitters
LIMITS = (  # what sizes a wall can have: particles, dispatches, emitted batches, textures
    "GL_MAX_SHADER_STORAGE_BLOCK_SIZE", "GL_MAX_SHADER_STORAGE_BUFFER_BINDINGS",
    "GL_MAX_COMPUTE_WORK_GROUP_COUNT", "GL_MAX_COMPUTE_WORK_GROUP_SIZE",
    "GL_MAX_COMPUTE_WORK_GROUP_INVOCATIONS", "GL_MAX_GEOMETRY_OUTPUT_VERTICES",
    "GL_MAX_GEOMETRY_OUTPUT_COMPONENTS", "GL_MAX_TEXTURE_SIZE", "GL_MAX_3D_TEXTURE_SIZE",
    "GL_MAX_TEXTURE_BUFFER_SIZE", "GL_MAX_RENDERBUFFER_SIZE", "GL_MAX_VIEWPORT_DIMS",
    "GL_MAX_SAMPLES", "GL_MAX_VERTEX_SHADER_STORAGE_BLOCKS",
)
NEEDS = (  # (limit, least value, what needs it) beyond GL 4.3 itself
    ("GL_MAX_GEOMETRY_OUTPUT_VERTICES", EMIT_BATCH, "the emitter pass writes a batch per "
                                                    "geometry-shader invocation"),
    ("GL_MAX_COMPUTE_WORK_GROUP_INVOCATIONS", WORKGROUP_SIZE, "the checksum's "
                                                                      "workgroup"),
)


def probe(index: int, extensions: tuple[str, ...] = (), timeout: float = PROBE_TIMEOUT) -> dict:
    """What EGL device `index` (with EGL device `extensions`) offers, from a child process;
    a crash or a hang is a finding."""
    command = [sys.executable, "-m", "cavesim.tools.doctor.probe", str(index)]
    fix = vendor_of(extensions).fix
    try:
        done = subprocess.run(command, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return _unusable(f"its probe did not finish within {timeout:.0f} s (a hung driver?)",
                         fix)
    lines = done.stdout.strip().splitlines()
    if done.returncode == 0 and lines:
        return json.loads(lines[-1])
    how = f"signal {-done.returncode}" if done.returncode < 0 else f"exit code {done.returncode}"
    said = (done.stderr.strip().splitlines() or ["nothing on stderr"])[-1]
    return _unusable(f"its probe ended with {how}: {said}", fix)


Smoke = Callable[[moderngl.Context, str], tuple[dict, list[tuple[str, str]]]]


def examine(index: int, driver: Driver | None = None, smoke: Smoke | None = None) -> dict:
    """Open device `index` as the engine does and say what it offers (the child's work).
    `driver` and `smoke` stand in for this machine's driver and GL programs in tests."""
    try:
        ctx = create_context(device=index, driver=driver)
    except ContextError as e:
        return _unusable(e.problem, e.fix)
    fix = vendor_of(ctx.extra["extensions"], ctx.info).fix
    found = {"opened": True, **describe(ctx), "gl_version_code": ctx.version_code,
             "limits": {name: _plain(ctx.info.get(name)) for name in LIMITS},
             **_capacity(ctx), "smoke": None}
    problems = _missing(ctx, fix)
    if not problems:
        found["smoke"], problems = (smoke or _smoke)(ctx, fix)
    ctx.release()
    problem, fix = problems[0] if problems else (None, None)
    return {**found, "usable": not problems, "problem": problem, "fix": fix}


def _capacity(ctx: moderngl.Context) -> dict:
    """The largest capacity the context allows, the limit that decides it, and the bytes
    of one particle buffer that large."""
    binding = capacity_limits(ctx.info).binding
    return {"largest_capacity": binding.capacity, "capacity_bound": binding.name,
            "state_bytes": binding.capacity * PARTICLE_BYTES}


def _missing(ctx: moderngl.Context, fix: str) -> list[tuple[str, str]]:
    """What the engine needs beyond GL 4.3 and this context lacks, as (problem, fix)."""
    return [(f"{name} is {ctx.info.get(name)}, at least {least} needed ({why})", fix)
            for name, least, why in NEEDS if _first(ctx.info.get(name, 0)) < least]


def _smoke(ctx: moderngl.Context, fix: str) -> tuple[dict, list[tuple[str, str]]]:
    """Compile the engine's checksum programs and run them once against numpy, with the
    counts from the host and from the GPU (the indirect dispatches)."""
    rng = np.random.default_rng(0)
    particles = rng.integers(0, 2**32, SMOKE_PARTICLES * PARTICLE_WORDS, dtype=np.uint32)
    emitters = rng.integers(0, 2**32, SMOKE_EMITTERS * EMITTER_WORDS, dtype=np.uint32)
    buffers = [ctx.buffer(particles.tobytes()), ctx.buffer(emitters.tobytes())]
    try:
        checksum = GpuChecksum(ctx, SMOKE_PARTICLES, SMOKE_EMITTERS, GpuFence(ctx))
        from_host = checksum.state(buffers[0], SMOKE_PARTICLES, buffers[1], SMOKE_EMITTERS, 1)
        checksum.run(buffers[0], buffers[1], 1)  # the counts from_host left on the GPU
        from_gpu = checksum.read()
    except (ShaderError, moderngl.Error) as e:
        detail = " ".join(str(e).split())
        return ({"ok": False, "detail": detail},
                [(f"the engine's checksum programs do not compile: {detail}", fix)])
    if not from_host == from_gpu == reference_checksum(particles, emitters, 1) \
            or ctx.error != "GL_NO_ERROR":
        detail = f"the checksum programs ran but disagree with numpy ({ctx.error})"
        return {"ok": False, "detail": detail}, [(detail, fix)]
    words = particles.size + emitters.size
    return {"ok": True, "detail": f"checksum programs compiled; {words:,} words hashed "
                                  f"as numpy does"}, []


def _unusable(problem: str, fix: str) -> dict:
    return {"opened": False, "usable": False, "problem": problem, "fix": fix}


def _plain(value):
    """A GL limit as JSON: tuples become lists."""
    return list(value) if isinstance(value, tuple) else value


def _first(value) -> float:
    return value[0] if isinstance(value, tuple) else value


if __name__ == "__main__":
    print(json.dumps(examine(int(sys.argv[1]))))
