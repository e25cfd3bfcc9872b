"""Whose driver a device runs, and so which fix fits it when it cannot run cavesim, and
how it waits.

One table: a vendor is recognised by a device extension only its EGL offers (before any
context exists) or by a word of its GL strings (after), and it has one fix. An NVIDIA
GPU is never told to install Mesa, and llvmpipe never to update a GPU driver. Whether a
blocking GL wait spins a core is the vendor's too (`cavesim.gpu.gl.fence` polls where it
does): NVIDIA's does (DESIGN.md); Mesa's sleeps on a condition; an unknown driver is
polled, to be safe.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

MESA_PACKAGES = "`apt-get install libegl1 libegl-mesa0 libgl1-mesa-dri`, or run deploy/setup.sh"


@dataclass(frozen=True)
class Vendor:
    name: str
    device_extension: str | None  # an EGL device extension that names this vendor's driver
    gl_word: str  # a word of GL_VENDOR, GL_RENDERER or GL_VERSION that names it
    fix: str  # what to install when its driver cannot give what cavesim needs
    waits_spin: bool = True  # its blocking waits (glFinish, reads, glClientWaitSync) spin


VENDORS = (  # first match wins: NVIDIA also lists EGL_EXT_device_drm, llvmpipe says "Mesa"
    Vendor("NVIDIA", "EGL_NV_device_cuda", "NVIDIA",
           "install NVIDIA's current driver for this GPU (it brings its EGL and OpenGL 4.6; "
           "`nvidia-smi` shows the one installed)"),
    Vendor("Mesa llvmpipe", "EGL_MESA_device_software", "llvmpipe",
           f"install Mesa 20 or newer ({MESA_PACKAGES}): llvmpipe gives OpenGL 4.5",
           waits_spin=False),
    Vendor("Mesa", "EGL_EXT_device_drm", "Mesa",
           f"install Mesa 20 or newer ({MESA_PACKAGES}): its AMD (radeonsi) and Intel (iris) "
           f"drivers give OpenGL 4.6", waits_spin=False),
)
UNKNOWN = Vendor("unknown", None, "", "install the GPU vendor's current OpenGL driver with "
                                      "its EGL library")


def vendor_of(device_extensions: tuple[str, ...] = (),
              gl: Mapping[str, object] | None = None) -> Vendor:
    """The vendor of a device, from its GL strings when a context opened, else from its EGL
    device extensions."""
    if gl:
        words = " ".join(str(gl.get(key, "")) for key in ("GL_VENDOR", "GL_RENDERER",
                                                          "GL_VERSION"))
        for vendor in VENDORS:
            if vendor.gl_word in words:
                return vendor
    for vendor in VENDORS:
        if vendor.device_extension in device_extensions:
            return vendor
    return UNKNOWN
