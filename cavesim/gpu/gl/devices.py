"""The EGL devices of this machine: the GPUs (and software renderers) a node can compute on.

glcontext opens its display on entry `device_index` of `eglQueryDevicesEXT`, so the index
listed here is the one `cavesim node --gpu` and a CAVE file's `gpu` key name. Listing
opens no GL context (ctypes on libEGL), so `cavesim run` can spread its walls over the
GPUs and `cavesim doctor` can name every device before it opens any.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import os
from dataclasses import dataclass

from cavesim.core.errors import ContextError

EGL_EXTENSIONS = 0x3055
EGL_DRM_DEVICE_FILE_EXT = 0x3233
EGL_RENDERER_EXT = 0x335F  # EGL_EXT_device_query_name
EGL_DRM_RENDER_NODE_FILE_EXT = 0x3377  # EGL_EXT_device_drm_render_node
SOFTWARE_EXTENSION = "EGL_MESA_device_software"
LIBRARY_VARIABLE = "GLCONTEXT_LINUX_LIBEGL"  # glcontext loads this library when it is set
VENDOR_VARIABLE = "__EGL_VENDOR_LIBRARY_FILENAMES"  # glvnd: which EGL drivers to load
PACKAGE_HINT = ("install the Debian packages libegl1, libegl-mesa0 and libgl1-mesa-dri "
                "(`apt-get install libegl1 libegl-mesa0 libgl1-mesa-dri`, or run deploy/setup.sh)"
                " or the GPU vendor's EGL driver")
LIST_HINT = "`cavesim doctor` lists the EGL devices"

_QUERY_DEVICES = ctypes.CFUNCTYPE(ctypes.c_uint, ctypes.c_int,
                                  ctypes.POINTER(ctypes.c_void_p), ctypes.POINTER(ctypes.c_int))
_QUERY_STRING = ctypes.CFUNCTYPE(ctypes.c_char_p, ctypes.c_void_p, ctypes.c_int)


@dataclass(frozen=True)
class EglDevice:
    """One entry of `eglQueryDevicesEXT`, with what the driver tells about it."""

    index: int
    extensions: tuple[str, ...]
    drm_file: str | None = None  # /dev/dri/cardN of a hardware device
    render_node: str | None = None  # /dev/dri/renderDN
    name: str | None = None  # the driver's name of the device, where it gives one

    @property
    def software(self) -> bool:
        """A CPU renderer (Mesa's llvmpipe): not a GPU to spread walls over."""
        return SOFTWARE_EXTENSION in self.extensions

    @property
    def kind(self) -> str:
        return "software" if self.software else "hardware"

    def summary(self) -> dict:
        """The device as JSON-ready values, for doctor.json."""
        return {"index": self.index, "kind": self.kind, "drm_file": self.drm_file,
                "render_node": self.render_node, "name": self.name,
                "extensions": list(self.extensions)}


def library_name() -> str | None:
    """The libEGL glcontext loads: $GLCONTEXT_LINUX_LIBEGL, else the system's libEGL."""
    return os.environ.get(LIBRARY_VARIABLE) or ctypes.util.find_library("EGL")


def list_devices() -> tuple[EglDevice, ...]:
    """Every EGL device in glcontext's order; ContextError if EGL cannot enumerate them."""
    egl = _load()
    egl.eglQueryString.restype = ctypes.c_char_p
    egl.eglQueryString.argtypes = [ctypes.c_void_p, ctypes.c_int]
    client = (egl.eglQueryString(None, EGL_EXTENSIONS) or b"").decode(errors="replace").split()
    if "EGL_EXT_device_enumeration" not in client:
        raise ContextError(f"libEGL loads, but no EGL driver offers "
                           f"EGL_EXT_device_enumeration{_vendor_note()}", PACKAGE_HINT)
    query_devices = _QUERY_DEVICES(_address(egl, "eglQueryDevicesEXT"))
    query_string = _QUERY_STRING(_address(egl, "eglQueryDeviceStringEXT"))
    count = ctypes.c_int()
    if not query_devices(0, None, ctypes.byref(count)):
        raise ContextError("eglQueryDevicesEXT failed to count the EGL devices", PACKAGE_HINT)
    handles = (ctypes.c_void_p * max(count.value, 1))()
    if count.value and not query_devices(count.value, handles, ctypes.byref(count)):
        raise ContextError("eglQueryDevicesEXT failed to list the EGL devices", PACKAGE_HINT)
    return tuple(_device(i, handles[i], query_string) for i in range(count.value))


def find_device(index: int) -> tuple[EglDevice, int]:
    """EGL device `index` and how many there are; ContextError naming both if it is absent."""
    devices = list_devices()
    if not 0 <= index < len(devices):
        raise no_such_device(index, devices)
    return devices[index], len(devices)


def no_such_device(index: int, devices: tuple[EglDevice, ...]) -> ContextError:
    """The error for an index past `devices`: names it and the devices there are."""
    listing = ", ".join(f"device {d.index} is {d.kind}" for d in devices) or "none"
    return ContextError(f"EGL device {index} does not exist: this machine has {len(devices)} "
                        f"EGL device(s) ({listing})", LIST_HINT if devices else PACKAGE_HINT)


def _load() -> ctypes.CDLL:
    name = library_name()
    if name is None:
        raise ContextError("libEGL is not installed", PACKAGE_HINT)
    try:
        return ctypes.CDLL(name)
    except OSError as e:
        raise ContextError(f"cannot load {name}: {e}", PACKAGE_HINT) from e


def _address(egl: ctypes.CDLL, function: str) -> int:
    egl.eglGetProcAddress.restype = ctypes.c_void_p
    egl.eglGetProcAddress.argtypes = [ctypes.c_char_p]
    address = egl.eglGetProcAddress(function.encode())
    if not address:
        raise ContextError(f"libEGL has no {function}{_vendor_note()}", PACKAGE_HINT)
    return address


def _device(index: int, handle: int, query_string) -> EglDevice:
    def text(name: int) -> str | None:
        value = query_string(handle, name)
        return value.decode(errors="replace") if value else None

    extensions = tuple((text(EGL_EXTENSIONS) or "").split())
    asked = {"drm_file": ("EGL_EXT_device_drm", EGL_DRM_DEVICE_FILE_EXT),
             "render_node": ("EGL_EXT_device_drm_render_node", EGL_DRM_RENDER_NODE_FILE_EXT),
             "name": ("EGL_EXT_device_query_name", EGL_RENDERER_EXT)}
    return EglDevice(index, extensions, **{field: text(name) if extension in extensions else None
                                           for field, (extension, name) in asked.items()})


def _vendor_note() -> str:
    """Why no driver may have loaded: glvnd was told to load only some vendor files."""
    chosen = os.environ.get(VENDOR_VARIABLE)
    return f" ({VENDOR_VARIABLE}={chosen!r} chooses the EGL drivers)" if chosen else ""
