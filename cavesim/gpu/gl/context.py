"""The headless OpenGL context every wall node (and every test) computes in.

A surfaceless EGL context has no default framebuffer, and Mesa refuses transform-feedback
draws without one (GL_INVALID_FRAMEBUFFER_OPERATION, nothing written), so the context is
handed out with a 1x1 framebuffer bound.

One context per process: creating a context makes it current, and moderngl does not
switch back, so a second context in the same process takes over the first one's calls.
That is the CAVE's own shape anyway: one wall node process, one context, on the EGL
device (GPU) the node was given (`cavesim.gpu.gl.devices`).
"""

from __future__ import annotations

import os
from collections.abc import Callable

import moderngl

from cavesim.core.errors import ContextError
from cavesim.gpu.gl.denormals import flushing_denormals
from cavesim.gpu.gl.devices import LIST_HINT, find_device
from cavesim.gpu.gl.driver import REQUIRED_GL_VERSION, Driver, SystemDriver
from cavesim.gpu.gl.vendors import vendor_of

DEVICE_VARIABLE = "GLCONTEXT_DEVICE_INDEX"  # glcontext lets it override device_index
SOFTWARE_RENDERERS = ("llvmpipe", "softpipe", "swrast")  # CPU renderers a display may give


def create_context(device: int | None = None, driver: Driver | None = None) -> moderngl.Context:
    """Open a standalone EGL context of GL 4.3 core on EGL device `device` (None: the
    default, device 0) with a tiny framebuffer bound; `driver`: this machine's by default."""
    driver = driver or SystemDriver()
    try:
        index = _device_index(device)
        egl_device, count = find_device(index, driver)
    except ContextError as e:
        raise ContextError(f"cannot open a headless OpenGL context: {e.problem}", e.fix) from e
    fix = vendor_of(egl_device.extensions).fix
    try:
        # the driver's threads start now and keep this thread's denormal mode: see
        # cavesim.gpu.gl.denormals (compute dispatches must round as draws do)
        with flushing_denormals():
            ctx = driver.open_context(index)
    except Exception as e:  # moderngl/glcontext raise plain Exception for a missing library
        message = " ".join(str(e).split())
        raise ContextError(f"cannot open a headless OpenGL context through EGL on device "
                           f"{index} ({egl_device.kind}, one of {count}): {message}",
                           f"{fix}; {LIST_HINT}") from e
    def load(name: str) -> int:  # glcontext's EGL loader, looked up when first needed
        return ctx.mglo._context.load(name)

    return _ready(ctx, load, f"EGL device {index}", egl_device.index, egl_device.kind,
                  egl_device.extensions)


def attach_context(load: Callable[[str], int]) -> moderngl.Context:
    """The context current on this thread (a window's, `cavesim.gpu.window`, made with GL
    4.3 core hints, whose GL functions `load` finds), made ready like a headless one. Its
    GPU is the X display's; device 0 in reports."""
    ctx = moderngl.create_context(require=REQUIRED_GL_VERSION)
    software = any(name in ctx.info["GL_RENDERER"] for name in SOFTWARE_RENDERERS)
    return _ready(ctx, load, f"the display {os.environ.get('DISPLAY')!r}", 0,
                  "software" if software else "hardware")


def version_text(code: int) -> str:
    """430 -> '4.3'."""
    return f"{code // 100}.{code % 100 // 10}"


def _ready(ctx: moderngl.Context, load: Callable[[str], int], where: str, device: int,
           kind: str, device_extensions: tuple[str, ...] = ()) -> moderngl.Context:
    """`ctx` checked for GL 4.3, with a tiny framebuffer bound for transform feedback, its
    device named for `gpu_of` and its GL function loader kept for what moderngl does not
    wrap (`cavesim.gpu.gl.fence`)."""
    if ctx.version_code < REQUIRED_GL_VERSION:
        found = ctx.info.get("GL_VERSION")
        fix = vendor_of(device_extensions, ctx.info).fix
        ctx.release()
        raise ContextError(f"OpenGL {version_text(REQUIRED_GL_VERSION)} core is required, "
                           f"{where} offers {found!r}", fix)
    framebuffer = ctx.simple_framebuffer((1, 1))
    framebuffer.use()
    ctx.extra = {"framebuffer": framebuffer, "device": device, "kind": kind,
                 "extensions": device_extensions, "load": load}
    return ctx


def describe(ctx: moderngl.Context) -> dict[str, str]:
    """Renderer, vendor and version strings, for reports."""
    keys = ("renderer", "vendor", "version")
    return {key: str(ctx.info.get(f"GL_{key.upper()}")) for key in keys}


def gpu_of(ctx: moderngl.Context) -> dict:
    """What a node computes on: the EGL device (index, hardware or software) and the GL
    renderer, vendor and version (the version names the driver), for logs and reports."""
    return {"device": ctx.extra["device"], "kind": ctx.extra["kind"], **describe(ctx)}


def _device_index(device: int | None) -> int:
    """The EGL device glcontext will open. Its GLCONTEXT_DEVICE_INDEX wins over the
    argument, so a conflict is an error here rather than a wrong name in the report."""
    text = os.environ.get(DEVICE_VARIABLE)
    if not text:
        return 0 if device is None else device
    try:
        forced = int(text)
    except ValueError:
        raise ContextError(f"{DEVICE_VARIABLE}={text!r} is not an EGL device index",
                           f"unset {DEVICE_VARIABLE} or give a whole number >= 0") from None
    if device is not None and device != forced:
        raise ContextError(f"{DEVICE_VARIABLE}={text} would override the requested EGL "
                           f"device {device}", f"unset {DEVICE_VARIABLE} to use device {device}")
    return forced
