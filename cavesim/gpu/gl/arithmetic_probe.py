"""The shaders' arithmetic (include/arithmetic.glsl) run on a context, function by function.

Portable mode promises the bits of the float32 numpy twin (cavesim.core.portable) on
every GPU; `run_function` gives this context's bits for any operands, `TWINS` the twin's,
so a test (or a check of a new GPU) compares them, and `time_calls` measures what a call
costs in either mode.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from contextlib import nullcontext

import moderngl
import numpy as np

from cavesim.core import portable
from cavesim.gpu.engine.programs import ARITHMETIC_IDS
from cavesim.gpu.gl.denormals import flushing_denormals
from cavesim.gpu.shader_source import ProgramSpec

ARITHMETIC_PROBE = ProgramSpec("probes/arithmetic.glsl", ("compute",),
                               ("ARITHMETIC", "FUNCTION", "REPEAT"))

Operands = np.ndarray  # float32, (cases, 3 operands a b c, 3 components x y z)
Twin = Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray]


def _scalar(function: Callable[..., np.ndarray], arity: int) -> Twin:
    return lambda a, b, c: function(*(a[:, 0], b[:, 0], c[:, 0])[:arity])


def _vector(function: Callable[..., np.ndarray], operands: str, width: int) -> Twin:
    """`function` of vectors of `width` (v) and scalars (s): "vs" is f_mul(vecN, float)."""
    def call(a, b, c):
        picked = [x[:, :width] if kind == "v" else x[:, :1]
                  for kind, x in zip(operands, (a, b, c), strict=False)]
        return function(*picked)
    return call


def _vec2(function: Callable[..., np.ndarray], operands: str) -> Twin:
    return _vector(function, operands, 2)


def _vec3(function: Callable[..., np.ndarray], operands: str) -> Twin:
    return _vector(function, operands, 3)


# In probes/arithmetic.glsl's FUNCTION order: each name, and the twin of its call there.
TWINS: dict[str, Twin] = {
    "f_ftz": _scalar(portable.f_ftz, 1),
    "f_add": _scalar(portable.f_add, 2),
    "f_sub": _scalar(portable.f_sub, 2),
    "f_mul": _scalar(portable.f_mul, 2),
    "f_div": _scalar(portable.f_div, 2),
    "f_sqrt": _scalar(portable.f_sqrt, 1),
    "f_exp": _scalar(portable.f_exp, 1),
    "f_log": _scalar(portable.f_log, 1),
    "f_pow": _scalar(portable.f_pow, 2),
    "f_sin": _scalar(portable.f_sin, 1),
    "f_cos": _scalar(portable.f_cos, 1),
    "f_mix": _scalar(portable.f_mix, 3),
    "f_dot vec3": lambda a, b, c: portable.f_dot(a, b),
    "f_dot vec2": lambda a, b, c: portable.f_dot(a[:, :2], b[:, :2]),
    "f_length vec3": lambda a, b, c: portable.f_length(a),
    "f_length vec2": lambda a, b, c: portable.f_length(a[:, :2]),
    "f_normalize vec3": lambda a, b, c: portable.f_normalize(a),
    "f_add vec3": _vec3(portable.f_add, "vv"),
    "f_sub vec3": _vec3(portable.f_sub, "vv"),
    "f_mul vec3": _vec3(portable.f_mul, "vv"),
    "f_mul float vec3": _vec3(portable.f_mul, "sv"),
    "f_mul vec3 float": _vec3(portable.f_mul, "vs"),
    "f_div vec3": _vec3(portable.f_div, "vv"),
    "f_div vec3 float": _vec3(portable.f_div, "vs"),
    "f_mix vec3": _vec3(portable.f_mix, "vvv"),
    "f_mix vec3 float": _vec3(portable.f_mix, "vvs"),
    "f_add vec2": _vec2(portable.f_add, "vv"),
    "f_sub vec2": _vec2(portable.f_sub, "vv"),
    "f_mul vec2": _vec2(portable.f_mul, "vv"),
    "f_mul float vec2": _vec2(portable.f_mul, "sv"),
    "f_mul vec2 float": _vec2(portable.f_mul, "vs"),
    "f_div vec2": _vec2(portable.f_div, "vv"),
    "f_div vec2 float": _vec2(portable.f_div, "vs"),
    "f_mix vec2": _vec2(portable.f_mix, "vvv"),
    "f_mix vec2 float": _vec2(portable.f_mix, "vvs"),
    "f_ftz vec3": lambda a, b, c: portable.f_ftz(a),
    "f_ftz vec2": lambda a, b, c: portable.f_ftz(a[:, :2]),
}
FUNCTIONS = tuple(TWINS)
_LOCAL_SIZE = 64  # as probes/arithmetic.glsl declares
_CHUNK = 65535 * _LOCAL_SIZE  # cases per dispatch: GL 4.3's smallest work group count


def probe_defines(function: str, arithmetic: str, repeat: int = 0) -> dict[str, int]:
    """The probe's defines for `function` (a FUNCTIONS name) in mode `arithmetic`."""
    if function not in TWINS:
        raise ValueError(f"function must be one of {FUNCTIONS}, got {function!r}")
    if arithmetic not in ARITHMETIC_IDS:  # the scene's Arithmetic, or its name
        raise ValueError(f"arithmetic must be one of {sorted(ARITHMETIC_IDS)}, "
                         f"got {arithmetic!r}")
    return {"ARITHMETIC": ARITHMETIC_IDS[arithmetic], "FUNCTION": FUNCTIONS.index(function),
            "REPEAT": repeat}


def twin_results(function: str, operands: Operands) -> np.ndarray:
    """The numpy twin's results of `function` as the probe writes them: (cases, 3) float32,
    a scalar result in the first column, zeros after the result's components."""
    _check(operands)
    result = TWINS[function](operands[:, 0], operands[:, 1], operands[:, 2])
    result = result.reshape(len(operands), -1)
    return np.pad(result, ((0, 0), (0, 3 - result.shape[1])))


def run_function(ctx: moderngl.Context, function: str, operands: Operands,
                 arithmetic: str = "portable", keep_denormals: bool = False) -> np.ndarray:
    """The context's results of `function` on each case, laid out as `twin_results`.

    Dispatched as the engine dispatches, with the hardware flushing subnormals, unless
    `keep_denormals`: then in this thread's own mode, which on llvmpipe with
    LP_NUM_THREADS=0 keeps subnormals as IEEE 754 says, like a GPU that does not flush.
    """
    _check(operands)
    program = ARITHMETIC_PROBE.build(ctx, probe_defines(function, arithmetic))
    try:
        return np.concatenate([
            _dispatch(ctx, program, operands[start:start + _CHUNK], keep_denormals)
            for start in range(0, len(operands), _CHUNK)])
    finally:
        program.release()


def time_calls(ctx: moderngl.Context, function: str, operands: Operands, arithmetic: str,
               repeat: int, runs: int = 3) -> float:
    """Seconds for `repeat` calls of `function` on every case, the best of `runs`."""
    _check(operands)
    if len(operands) > _CHUNK:
        raise ValueError(f"time at most {_CHUNK} cases, got {len(operands)}")
    program = ARITHMETIC_PROBE.build(ctx, probe_defines(function, arithmetic, repeat))
    try:
        _dispatch(ctx, program, operands)  # warm: the driver compiles on first use
        times = []
        for _ in range(runs):
            start = time.perf_counter()
            _dispatch(ctx, program, operands)
            times.append(time.perf_counter() - start)
        return min(times)
    finally:
        program.release()


def _check(operands: Operands) -> None:
    if operands.dtype != np.float32 or operands.ndim != 3 or operands.shape[1:] != (3, 3):
        raise ValueError(f"operands must be float32 of shape (cases, 3, 3), got "
                         f"{operands.dtype} {operands.shape}")


def _dispatch(ctx: moderngl.Context, program: moderngl.ComputeShader,
              operands: Operands, keep_denormals: bool = False) -> np.ndarray:
    source = ctx.buffer(np.ascontiguousarray(operands).tobytes())
    results = ctx.buffer(reserve=len(operands) * 3 * 4)
    try:
        source.bind_to_storage_buffer(0)
        results.bind_to_storage_buffer(1)
        program["case_count"].value = len(operands)
        # as the engine dispatches (cavesim.gpu.gl.denormals), or as a GPU that keeps them
        with nullcontext() if keep_denormals else flushing_denormals():
            program.run(-(-len(operands) // _LOCAL_SIZE))
        ctx.memory_barrier()
        return np.frombuffer(results.read(), dtype=np.float32).reshape(-1, 3)
    finally:
        source.release()
        results.release()
