"""The driver boundary: the few EGL and GL calls cavesim makes to list devices and open a
context, behind one small interface.

Everything cavesim decides about a driver (which extensions list devices, which device
is which, what a context offers, how many particles fit, what the doctor says) is
computed from these answers alone, so a test can put a recorded driver in their place
(`tests/data/drivers/*.json`: NVIDIA, Mesa on a GPU, llvmpipe) and check each decision
against what that driver really answers, on a machine that has none of them.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import os
from collections.abc import Sequence
from functools import cached_property
from typing import Protocol

import moderngl

from cavesim.core.errors import ContextError

# compute shaders, SSBOs (GS + TF need 3.3); every program's #version. Every context asks
# for it: a driver gives what is asked (NVIDIA: 3.3 when nothing is), not the most it can.
REQUIRED_GL_VERSION = 430
EGL_EXTENSIONS = 0x3055
LIBRARY_VARIABLE = "GLCONTEXT_LINUX_LIBEGL"  # glcontext loads this library when it is set
VENDOR_VARIABLE = "__EGL_VENDOR_LIBRARY_FILENAMES"  # glvnd: which EGL drivers to load
PACKAGE_HINT = ("install the Debian packages libegl1, libegl-mesa0 and libgl1-mesa-dri "
                "(`apt-get install libegl1 libegl-mesa0 libgl1-mesa-dri`, or run deploy/setup.sh)"
                " or the GPU vendor's EGL driver")

_QUERY_DEVICES = ctypes.CFUNCTYPE(ctypes.c_uint, ctypes.c_int,
                                  ctypes.POINTER(ctypes.c_void_p), ctypes.POINTER(ctypes.c_int))
_QUERY_STRING = ctypes.CFUNCTYPE(ctypes.c_char_p, ctypes.c_void_p, ctypes.c_int)


class Driver(Protocol):
    """What cavesim asks of EGL and GL before it computes anything."""

    def client_extensions(self) -> str:
        """`eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS)`: the client extensions."""

    def device_handles(self) -> Sequence[object]:
        """`eglQueryDevicesEXT`: every EGL device, in the order glcontext indexes them."""

    def device_string(self, handle: object, name: int) -> str | None:
        """`eglQueryDeviceStringEXT(handle, name)`, None where the driver gives nothing."""

    def open_context(self, device_index: int) -> moderngl.Context:
        """A standalone EGL context on device `device_index`, asking for GL 4.3 core."""


class SystemDriver:
    """This machine's libEGL (through ctypes) and moderngl's EGL backend (glcontext)."""

    def __init__(self) -> None:
        self._egl = _load()
        self._egl.eglQueryString.restype = ctypes.c_char_p
        self._egl.eglQueryString.argtypes = [ctypes.c_void_p, ctypes.c_int]

    def client_extensions(self) -> str:
        return (self._egl.eglQueryString(None, EGL_EXTENSIONS) or b"").decode(errors="replace")

    def device_handles(self) -> Sequence[object]:
        query_devices = _QUERY_DEVICES(self._address("eglQueryDevicesEXT"))
        count = ctypes.c_int()
        if not query_devices(0, None, ctypes.byref(count)):
            raise ContextError("eglQueryDevicesEXT failed to count the EGL devices", PACKAGE_HINT)
        handles = (ctypes.c_void_p * max(count.value, 1))()
        if count.value and not query_devices(count.value, handles, ctypes.byref(count)):
            raise ContextError("eglQueryDevicesEXT failed to list the EGL devices", PACKAGE_HINT)
        return tuple(handles[i] for i in range(count.value))

    def device_string(self, handle: object, name: int) -> str | None:
        value = self._query_string(handle, name)
        return value.decode(errors="replace") if value else None

    @cached_property
    def _query_string(self):
        """eglQueryDeviceStringEXT, looked up once (after the listing checked its extension)."""
        return _QUERY_STRING(self._address("eglQueryDeviceStringEXT"))

    def open_context(self, device_index: int) -> moderngl.Context:
        return moderngl.create_standalone_context(backend="egl", require=REQUIRED_GL_VERSION,
                                                  device_index=device_index)

    def _address(self, function: str) -> int:
        self._egl.eglGetProcAddress.restype = ctypes.c_void_p
        self._egl.eglGetProcAddress.argtypes = [ctypes.c_char_p]
        address = self._egl.eglGetProcAddress(function.encode())
        if not address:
            raise ContextError(f"libEGL has no {function}{vendor_note()}", PACKAGE_HINT)
        return address


def library_name() -> str | None:
    """The libEGL glcontext loads: $GLCONTEXT_LINUX_LIBEGL, else the system's libEGL."""
    return os.environ.get(LIBRARY_VARIABLE) or ctypes.util.find_library("EGL")


def vendor_note() -> str:
    """Why no driver may have loaded: glvnd was told to load only some vendor files."""
    chosen = os.environ.get(VENDOR_VARIABLE)
    return f" ({VENDOR_VARIABLE}={chosen!r} chooses the EGL drivers)" if chosen else ""


def _load() -> ctypes.CDLL:
    name = library_name()
    if name is None:
        raise ContextError("libEGL is not installed", PACKAGE_HINT)
    try:
        return ctypes.CDLL(name)
    except OSError as e:
        raise ContextError(f"cannot load {name}: {e}", PACKAGE_HINT) from e
