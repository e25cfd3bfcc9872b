"""Waiting for the GPU without spinning a core: a fence (glFenceSync) polled with short
sleeps, before each read of what the GPU computed.

A plain read (glGetBufferSubData, a query's result, glFinish) blocks inside the driver, and
NVIDIA's driver spins a core while it does: on a node of several walls, or a host of several
nodes, that core is taken from the others. On such a driver (`Vendor.waits_spin`) the node
lets the driver wait at most FIRST_WAIT_NS (a short frame is done by then) and then sleeps
POLL_SECONDS between looks, so a long wait costs a few wake-ups, not a core. A driver that
sleeps in its own wait (Mesa) is left to wait, which wakes the node the moment the GPU is
done. Either way the read that follows finds its data ready. Every wait has a limit
(WAIT_LIMIT_SECONDS): a GPU that hangs ends the node with one line instead of holding the
cluster forever.

moderngl has no sync objects: the three GL functions come from the context's own loader
(EGL's for a headless context, GLFW's for a window's).
"""

from __future__ import annotations

import ctypes
import time
from collections.abc import Mapping

import moderngl

from cavesim.core.errors import ContextError
from cavesim.gpu.gl.vendors import vendor_of

GL_SYNC_GPU_COMMANDS_COMPLETE = 0x9117
GL_SYNC_FLUSH_COMMANDS_BIT = 0x00000001
GL_ALREADY_SIGNALED, GL_TIMEOUT_EXPIRED, GL_CONDITION_SATISFIED, GL_WAIT_FAILED = (
    0x911A, 0x911B, 0x911C, 0x911D)
FIRST_WAIT_NS = 50_000  # a spinning driver's own wait, once: most frames are done within it
POLL_SECONDS = 100e-6  # then between two looks at the fence
WAIT_LIMIT_SECONDS = 30.0  # a frame's GPU work that takes longer is a hung GPU

_FENCE_SYNC = ctypes.CFUNCTYPE(ctypes.c_void_p, ctypes.c_uint, ctypes.c_uint)
_CLIENT_WAIT_SYNC = ctypes.CFUNCTYPE(ctypes.c_uint, ctypes.c_void_p, ctypes.c_uint,
                                     ctypes.c_uint64)
_DELETE_SYNC = ctypes.CFUNCTYPE(None, ctypes.c_void_p)


def first_wait_ns(device_extensions: tuple[str, ...], gl: Mapping[str, object]) -> int:
    """How long the driver's own wait may take before the node polls: FIRST_WAIT_NS where
    it would spin, the whole limit where it sleeps."""
    spins = vendor_of(device_extensions, gl).waits_spin
    return FIRST_WAIT_NS if spins else int(WAIT_LIMIT_SECONDS * 1e9)


class GpuFence:
    """`wait()`: return once the GPU has done every command issued so far; `waited` adds up
    the seconds spent waiting, for the node's frame cost (`take_waited` reads and clears
    it)."""

    def __init__(self, ctx: moderngl.Context) -> None:
        load = ctx.extra["load"]  # the context's GL loader (cavesim.gpu.gl.context)
        self.first_wait_ns = first_wait_ns(ctx.extra["extensions"], ctx.info)
        self._fence_sync = _FENCE_SYNC(load("glFenceSync"))
        self._client_wait_sync = _CLIENT_WAIT_SYNC(load("glClientWaitSync"))
        self._delete_sync = _DELETE_SYNC(load("glDeleteSync"))
        self.waited = 0.0

    def wait(self) -> None:
        started = time.perf_counter()
        sync = self._fence_sync(GL_SYNC_GPU_COMMANDS_COMPLETE, 0)
        try:
            # the first look sends the commands on and lets the driver wait briefly
            status = self._client_wait_sync(sync, GL_SYNC_FLUSH_COMMANDS_BIT,
                                            self.first_wait_ns)
            while status == GL_TIMEOUT_EXPIRED:
                if time.perf_counter() - started > WAIT_LIMIT_SECONDS:
                    raise ContextError(f"the GPU did not finish a frame's work within "
                                       f"{WAIT_LIMIT_SECONDS:g} s",
                                       "check the GPU with `cavesim doctor`; a smaller scene "
                                       "(capacity) may fit")
                time.sleep(POLL_SECONDS)
                status = self._client_wait_sync(sync, 0, 0)
            if status == GL_WAIT_FAILED:
                raise ContextError("glClientWaitSync failed while waiting for the GPU",
                                   "the context was lost; restart the node")
        finally:
            self._delete_sync(sync)
            self.waited += time.perf_counter() - started

    def take_waited(self) -> float:
        """The seconds waited since the last call."""
        waited, self.waited = self.waited, 0.0
        return waited
