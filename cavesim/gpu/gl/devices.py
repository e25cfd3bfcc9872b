"""The EGL devices of this machine: the GPUs (and software renderers) a node can compute on.

glcontext opens its display on entry `device_index` of `eglQueryDevicesEXT`, so the index
listed here is the one `cavesim node --gpu` and a CAVE file's `gpu` key name. Listing
opens no GL context (ctypes on libEGL), so `cavesim run` can spread its walls over the
GPUs and `cavesim doctor` can name every device before it opens any.
"""

from __future__ import annotations

from dataclasses import dataclass

from cavesim.core.errors import ContextError
from cavesim.gpu.gl.driver import EGL_EXTENSIONS, PACKAGE_HINT, Driver, SystemDriver, vendor_note

EGL_DRM_DEVICE_FILE_EXT = 0x3233
EGL_RENDERER_EXT = 0x335F  # EGL_EXT_device_query_name
EGL_DRM_RENDER_NODE_FILE_EXT = 0x3377  # EGL_EXT_device_drm_render_node
SOFTWARE_EXTENSION = "EGL_MESA_device_software"
# Client extensions that list devices and query them: either set will do. EGL_EXT_device_base
# is the older name of the two together (NVIDIA's libEGL lists only it).
DEVICE_LISTING = (("EGL_EXT_device_enumeration", "EGL_EXT_device_query"),
                  ("EGL_EXT_device_base",))
LIST_HINT = "`cavesim doctor` lists the EGL devices"


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


def list_devices(driver: Driver | None = None) -> tuple[EglDevice, ...]:
    """Every EGL device in glcontext's order; ContextError if EGL cannot enumerate them."""
    driver = driver or SystemDriver()
    client = driver.client_extensions().split()
    if not any(all(name in client for name in names) for names in DEVICE_LISTING):
        wanted = " or ".join(" + ".join(names) for names in DEVICE_LISTING)
        raise ContextError(f"libEGL loads, but no EGL driver offers {wanted}{vendor_note()}",
                           PACKAGE_HINT)
    return tuple(_device(i, handle, driver) for i, handle in enumerate(driver.device_handles()))


def find_device(index: int, driver: Driver | None = None) -> tuple[EglDevice, int]:
    """EGL device `index` and how many there are; ContextError naming both if it is absent."""
    devices = list_devices(driver)
    if not 0 <= index < len(devices):
        raise no_such_device(index, devices)
    return devices[index], len(devices)


def no_such_device(index: int, devices: tuple[EglDevice, ...]) -> ContextError:
    """The error for an index past `devices`: names it and the devices there are."""
    listing = ", ".join(f"device {d.index} is {d.kind}" for d in devices) or "none"
    return ContextError(f"EGL device {index} does not exist: this machine has {len(devices)} "
                        f"EGL device(s) ({listing})", LIST_HINT if devices else PACKAGE_HINT)


def _device(index: int, handle: object, driver: Driver) -> EglDevice:
    def text(name: int) -> str | None:
        return driver.device_string(handle, name)

    extensions = tuple((text(EGL_EXTENSIONS) or "").split())
    asked = {"drm_file": ("EGL_EXT_device_drm", EGL_DRM_DEVICE_FILE_EXT),
             "render_node": ("EGL_EXT_device_drm_render_node", EGL_DRM_RENDER_NODE_FILE_EXT),
             "name": ("EGL_EXT_device_query_name", EGL_RENDERER_EXT)}
    return EglDevice(index, extensions, **{field: text(name) if extension in extensions else None
                                           for field, (extension, name) in asked.items()})
