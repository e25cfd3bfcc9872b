"""One EGL device examined in a child process of its own: `python -m cavesim.tools.doctor.probe N`.

A child per device, because a process holds one GL context (a second one takes over the
first one's calls), and because a broken driver may crash or hang while opening one: the
doctor must still reach its verdict, so the child has a deadline. The child opens any
core context, so a driver too old for cavesim is still described, then checks what the
engine needs and runs the engine's checksum programs once against numpy.
"""

from __future__ import annotations

import json
import subprocess
import sys

import moderngl
import numpy as np

from cavesim.core.digest.reference import reference_checksum
from cavesim.core.digest.shape import WORKGROUP_SIZE
from cavesim.core.emitters import EMIT_BATCH
from cavesim.core.errors import ContextError, ShaderError
from cavesim.core.records import EMITTER_WORDS, PARTICLE_WORDS
from cavesim.gpu.engine.capacity import capacity_limits
from cavesim.gpu.engine.checksum import GpuChecksum
from cavesim.gpu.gl.context import REQUIRED_GL_VERSION, create_context, describe

PROBE_TIMEOUT = 60.0  # s for one device: open a context, compile, run the checksum once
OPEN_VERSION = 330  # any core context: describe even a driver cavesim cannot use
SMOKE_PARTICLES, SMOKE_EMITTERS = 4_000, 3  # three sums work groups, a partial one, emitters
DRIVER_FIX = ("install Mesa 20 or newer (`apt-get install libegl-mesa0 libgl1-mesa-dri`: "
              "llvmpipe gives OpenGL 4.5) or the GPU vendor's current driver")
LIMITS = (  # what sizes a wall can have: particles, dispatches, emitted batches, textures
    "GL_MAX_SHADER_STORAGE_BLOCK_SIZE", "GL_MAX_SHADER_STORAGE_BUFFER_BINDINGS",
    "GL_MAX_COMPUTE_WORK_GROUP_COUNT", "GL_MAX_COMPUTE_WORK_GROUP_SIZE",
    "GL_MAX_COMPUTE_WORK_GROUP_INVOCATIONS", "GL_MAX_GEOMETRY_OUTPUT_VERTICES",
    "GL_MAX_GEOMETRY_OUTPUT_COMPONENTS", "GL_MAX_TEXTURE_SIZE", "GL_MAX_3D_TEXTURE_SIZE",
    "GL_MAX_TEXTURE_BUFFER_SIZE", "GL_MAX_RENDERBUFFER_SIZE", "GL_MAX_VIEWPORT_DIMS",
    "GL_MAX_SAMPLES",
)
NEEDS = (  # (limit, least value, what needs it) beyond GL 4.3 itself
    ("GL_MAX_GEOMETRY_OUTPUT_VERTICES", EMIT_BATCH, "the emitter pass writes a batch per "
                                                    "geometry-shader invocation"),
    ("GL_MAX_COMPUTE_WORK_GROUP_INVOCATIONS", WORKGROUP_SIZE, "the checksum's "
                                                                      "workgroup"),
)


def probe(index: int, timeout: float = PROBE_TIMEOUT) -> dict:
    """What EGL device `index` offers, from a child process; a crash or a hang is a finding."""
    command = [sys.executable, "-m", "cavesim.tools.doctor.probe", str(index)]
    try:
        done = subprocess.run(command, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return _unusable(f"its probe did not finish within {timeout:.0f} s (a hung driver?)",
                         DRIVER_FIX)
    lines = done.stdout.strip().splitlines()
    if done.returncode == 0 and lines:
        return json.loads(lines[-1])
    how = f"signal {-done.returncode}" if done.returncode < 0 else f"exit code {done.returncode}"
    said = (done.stderr.strip().splitlines() or ["nothing on stderr"])[-1]
    return _unusable(f"its probe ended with {how}: {said}", DRIVER_FIX)


def examine(index: int) -> dict:
    """Open device `index` in this process and say what it offers (the child's work)."""
    try:
        ctx = create_context(require=OPEN_VERSION, device=index)
    except ContextError as e:
        return _unusable(e.problem, e.fix)
    found = {"opened": True, **describe(ctx), "gl_version_code": ctx.version_code,
             "limits": {name: _plain(ctx.info.get(name)) for name in LIMITS},
             **_capacity(ctx), "smoke": None}
    problems = _missing(ctx)
    if not problems:
        found["smoke"], problems = _smoke(ctx)
    ctx.release()
    problem, fix = problems[0] if problems else (None, None)
    return {**found, "usable": not problems, "problem": problem, "fix": fix}


def _capacity(ctx: moderngl.Context) -> dict:
    """The largest capacity the context allows and the limit that decides it."""
    if ctx.version_code < REQUIRED_GL_VERSION:  # no storage blocks to bound it
        return {"largest_capacity": 0, "capacity_bound": None}
    binding = capacity_limits(ctx.info).binding
    return {"largest_capacity": binding.capacity, "capacity_bound": binding.name}


def _missing(ctx: moderngl.Context) -> list[tuple[str, str]]:
    """What the engine needs and this context lacks, as (problem, fix)."""
    if ctx.version_code < REQUIRED_GL_VERSION:
        return [(f"OpenGL {REQUIRED_GL_VERSION // 100}.{REQUIRED_GL_VERSION % 100 // 10} core "
                 f"is required, the driver offers {ctx.info['GL_VERSION']!r}", DRIVER_FIX)]
    return [(f"{name} is {ctx.info.get(name)}, at least {least} needed ({why})", DRIVER_FIX)
            for name, least, why in NEEDS if _first(ctx.info.get(name, 0)) < least]


def _smoke(ctx: moderngl.Context) -> tuple[dict, list[tuple[str, str]]]:
    """Compile the engine's checksum programs and run them once against numpy, with the
    counts from the host and from the GPU (the indirect dispatches)."""
    rng = np.random.default_rng(0)
    particles = rng.integers(0, 2**32, SMOKE_PARTICLES * PARTICLE_WORDS, dtype=np.uint32)
    emitters = rng.integers(0, 2**32, SMOKE_EMITTERS * EMITTER_WORDS, dtype=np.uint32)
    buffers = [ctx.buffer(particles.tobytes()), ctx.buffer(emitters.tobytes())]
    try:
        checksum = GpuChecksum(ctx, SMOKE_PARTICLES, SMOKE_EMITTERS)
        from_host = checksum.state(buffers[0], SMOKE_PARTICLES, buffers[1], SMOKE_EMITTERS, 1)
        checksum.run(buffers[0], buffers[1], 1)  # the counts from_host left on the GPU
        from_gpu = checksum.read()
    except (ShaderError, moderngl.Error) as e:
        detail = " ".join(str(e).split())
        return ({"ok": False, "detail": detail},
                [(f"the engine's checksum programs do not compile: {detail}", DRIVER_FIX)])
    if not from_host == from_gpu == reference_checksum(particles, emitters, 1) \
            or ctx.error != "GL_NO_ERROR":
        detail = f"the checksum programs ran but disagree with numpy ({ctx.error})"
        return {"ok": False, "detail": detail}, [(detail, DRIVER_FIX)]
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
