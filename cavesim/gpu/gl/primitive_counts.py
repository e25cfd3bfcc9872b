"""How many records a transform-feedback pass generated, landed in a buffer the GPU reads.

A GL_PRIMITIVES_GENERATED query around a pass counts its records. Where the context offers
query buffer objects (OpenGL 4.4, or GL_ARB_query_buffer_object before it), the driver
writes the result into a buffer on the GPU, in command order, and the passes that follow
read it there: the host never waits for it. Elsewhere the host waits for the result on the
frame's fence and writes it into the same place: the same bytes, one wait more.

moderngl wraps neither the query's name nor the query buffer binding, so the five GL
functions come from the context's own loader, as the fence's do.
"""

from __future__ import annotations

import ctypes
from collections.abc import Iterator
from contextlib import contextmanager

import moderngl
import numpy as np

from cavesim.gpu.gl.fence import GpuFence

GL_PRIMITIVES_GENERATED = 0x8C87
GL_QUERY_RESULT = 0x8866
GL_QUERY_BUFFER = 0x9192
QUERY_BUFFER_VERSION = 440  # query buffer objects are core from OpenGL 4.4
QUERY_BUFFER_EXTENSION = "GL_ARB_query_buffer_object"

_GEN_QUERIES = ctypes.CFUNCTYPE(None, ctypes.c_int, ctypes.POINTER(ctypes.c_uint))
_BEGIN_QUERY = ctypes.CFUNCTYPE(None, ctypes.c_uint, ctypes.c_uint)
_END_QUERY = ctypes.CFUNCTYPE(None, ctypes.c_uint)
_GET_QUERY_OBJECT = ctypes.CFUNCTYPE(None, ctypes.c_uint, ctypes.c_uint, ctypes.c_void_p)
_BIND_BUFFER = ctypes.CFUNCTYPE(None, ctypes.c_uint, ctypes.c_uint)


def query_buffers_offered(version_code: int, extensions: set[str] | frozenset[str]) -> bool:
    """Whether a context of this version and these extensions writes query results into
    buffers."""
    return version_code >= QUERY_BUFFER_VERSION or QUERY_BUFFER_EXTENSION in extensions


class PrimitiveCounts:
    """`counting(offset)` around a pass lands its generated records, a uint, at byte
    `offset` of `into`; `on_gpu` says whether the host stays out of it."""

    def __init__(self, ctx: moderngl.Context, into: moderngl.Buffer, fence: GpuFence) -> None:
        load = ctx.extra["load"]  # the context's GL loader (cavesim.gpu.gl.context)
        self.on_gpu = query_buffers_offered(ctx.version_code, ctx.extensions)
        self._into, self._fence = into, fence
        self._begin = _BEGIN_QUERY(load("glBeginQuery"))
        self._end = _END_QUERY(load("glEndQuery"))
        self._get = _GET_QUERY_OBJECT(load("glGetQueryObjectuiv"))
        self._bind = _BIND_BUFFER(load("glBindBuffer"))
        name = ctypes.c_uint(0)
        _GEN_QUERIES(load("glGenQueries"))(1, ctypes.byref(name))
        self._query = name.value
        self._result = ctypes.c_uint(0)

    @contextmanager
    def counting(self, offset: int) -> Iterator[None]:
        self._begin(GL_PRIMITIVES_GENERATED, self._query)
        try:
            yield
        finally:
            self._end(GL_PRIMITIVES_GENERATED)
        if self.on_gpu:
            self._bind(GL_QUERY_BUFFER, self._into.glo)
            self._get(self._query, GL_QUERY_RESULT, ctypes.c_void_p(offset))
            self._bind(GL_QUERY_BUFFER, 0)
        else:
            self._fence.wait()  # the result is in; reading it no longer blocks in the driver
            self._get(self._query, GL_QUERY_RESULT, ctypes.addressof(self._result))
            self.put(offset, self._result.value)

    def put(self, offset: int, count: int) -> None:
        """Land a count the host knows (a pass that did not run generated nothing)."""
        self._into.write(np.array([count], "<u4").tobytes(), offset=offset)
