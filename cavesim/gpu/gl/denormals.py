"""Denormal floats, handled the same by draws and compute dispatches on software GL.

llvmpipe runs vertex and geometry shaders with the SSE modes flush-to-zero and
denormals-are-zero set (D3D10's rule; Mesa sets them around every draw), but runs compute
shaders in whatever mode their thread has: its compute workers inherit the mode of the
thread that created the GL screen, and with LP_NUM_THREADS=0 a dispatch runs on the
calling thread. Left alone, a compute pass keeps the denormals a transform-feedback pass
flushes (dust at rest under exponential drag reaches them within frames), and the two
engine paths part after a few hundred frames. So the context is created, and every compute
dispatch of the engine runs, with both modes set (`flushing_denormals`);
`cavesim.gpu.gl.denormal_probe` measures whether draws and dispatches then agree on a
context, whatever its driver.

The modes are set through glibc's fenv on x86-64 (MXCSR); elsewhere llvmpipe sets nothing
either, and `flushing_denormals` does nothing.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import platform
from collections.abc import Iterator
from contextlib import contextmanager
from functools import cache

FLUSH_TO_ZERO = 0x8000  # MXCSR bits (Intel SDM vol. 1, 10.2.3)
DENORMALS_ARE_ZERO = 0x0040


class _Fenv(ctypes.Structure):
    """glibc's x86-64 fenv_t: the x87 environment, then MXCSR."""

    _fields_ = [("x87", ctypes.c_uint8 * 28), ("mxcsr", ctypes.c_uint32)]


@cache
def _libm() -> ctypes.CDLL | None:
    if platform.machine().lower() not in ("x86_64", "amd64"):
        return None
    name = ctypes.util.find_library("m")
    return ctypes.CDLL(name) if name else None


@contextmanager
def flushing_denormals() -> Iterator[None]:
    """Flush-to-zero and denormals-are-zero on this thread within the block."""
    libm = _libm()
    if libm is None:
        yield
        return
    saved = _Fenv()
    libm.fegetenv(ctypes.byref(saved))
    flushing = _Fenv.from_buffer_copy(saved)
    flushing.mxcsr |= FLUSH_TO_ZERO | DENORMALS_ARE_ZERO
    libm.fesetenv(ctypes.byref(flushing))
    try:
        yield
    finally:
        libm.fesetenv(ctypes.byref(saved))
