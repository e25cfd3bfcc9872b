"""A wall's window on its display: a GLFW window whose GL context is the node's only
context, the presentation of the wall's picture into it (mono, quad-buffered stereo, or
side-by-side / top-bottom frame packing), and the swap.

The picture is drawn by the same renderer as the headless PNGs (`WallRenderer.draw` into
its picture texture) and presented with a textured triangle, so the window shows those
pixels: one to one when the window has the wall's resolution, scaled otherwise. Quad
stereo needs a visual the driver offers; where it offers none the window falls back to
side-by-side packing and says so.
"""

from __future__ import annotations

import ctypes
import logging
import os
import time
from dataclasses import dataclass

import glfw
import moderngl
import numpy as np

from cavesim.core.cave.geometry import Display, StereoMode
from cavesim.core.errors import ContextError
from cavesim.gpu.gl.context import REQUIRED_GL_VERSION, attach_context
from cavesim.gpu.gl.denormals import flushing_denormals
from cavesim.gpu.render.programs import PRESENT
from cavesim.gpu.render.text import TextLine

log = logging.getLogger("cavesim.window")
GL_BACK, GL_BACK_LEFT, GL_BACK_RIGHT = 0x0405, 0x0402, 0x0403
Region = tuple[float, float, float, float]  # x, y, width, height: fractions of the window
WHOLE: Region = (0.0, 0.0, 1.0, 1.0)


@dataclass
class WallWindow:
    window: object  # the GLFW window
    ctx: moderngl.Context
    stereo: StereoMode  # as shown: QUAD only where the driver offered a stereo visual

    def __post_init__(self) -> None:
        self._present = PRESENT.build(self.ctx, {})
        self._triangle = self.ctx.vertex_array(self._present, [])
        address = glfw.get_proc_address("glDrawBuffer")
        self._draw_buffer = ctypes.CFUNCTYPE(None, ctypes.c_uint)(address)

    @property
    def size(self) -> tuple[int, int]:
        """The window's framebuffer in pixels."""
        return tuple(glfw.get_framebuffer_size(self.window))

    def should_close(self) -> bool:
        """Handle the window system's events; whether the window was asked to close."""
        glfw.poll_events()
        return bool(glfw.window_should_close(self.window))

    def present(self, picture: moderngl.Texture, eye: str,
                region: Region = WHOLE) -> None:
        """Put an eye's picture ("center", "left" or "right") into the back buffer, in
        `region` of the window (a node of several walls gives each its own)."""
        x, y, width, height = self._pixels(region)
        viewport = (x, y, width, height)
        if eye != "center" and self.stereo is StereoMode.SIDE_BY_SIDE:
            viewport = (x if eye == "left" else x + width // 2, y, width // 2, height)
        elif eye != "center" and self.stereo is StereoMode.TOP_BOTTOM:
            viewport = (x, y + height // 2 if eye == "left" else y, width, height // 2)
        screen = self.ctx.screen
        screen.use()
        if eye != "center" and self.stereo is StereoMode.QUAD:
            self._draw_buffer(GL_BACK_LEFT if eye == "left" else GL_BACK_RIGHT)
        screen.viewport = viewport
        exact = viewport[2:] == picture.size
        picture.filter = (moderngl.NEAREST, moderngl.NEAREST) if exact else (
            moderngl.LINEAR, moderngl.LINEAR)
        picture.use(0)
        self._present["picture"].value = 0
        self._triangle.render(moderngl.TRIANGLES, vertices=3)
        if self.stereo is StereoMode.QUAD:
            self._draw_buffer(GL_BACK)
        screen.viewport = (0, 0, *self.size)
        self.ctx.extra["framebuffer"].use()  # the engine's transform feedback needs it bound

    def overlay(self, line: TextLine, at: tuple[int, int] = (0, 0)) -> None:
        """Blend a line of text into the back buffer, `at` pixels from its lower left."""
        self.ctx.screen.use()
        line.draw(self.size, at)
        self.ctx.extra["framebuffer"].use()

    def set_title(self, title: str) -> None:
        glfw.set_window_title(self.window, title)

    def read(self, region: Region = WHOLE) -> np.ndarray:
        """The back buffer (in `region`) as it is about to be shown: (height, width, 3)
        uint8, row 0 on top."""
        x, y, width, height = self._pixels(region)
        pixels = self.ctx.screen.read(viewport=(x, y, width, height), components=3)
        self.ctx.extra["framebuffer"].use()
        return np.frombuffer(pixels, np.uint8).reshape(height, width, 3)[::-1].copy()

    def _pixels(self, region: Region) -> tuple[int, int, int, int]:
        """`region` (fractions of the window, from its lower left) in framebuffer pixels."""
        width, height = self.size
        x0, y0 = round(region[0] * width), round(region[1] * height)
        x1 = round((region[0] + region[2]) * width)
        y1 = round((region[1] + region[3]) * height)
        return x0, y0, x1 - x0, y1 - y0

    def swap(self) -> int:
        """Show the back buffer; the monotonic clock (ns) when the swap returned."""
        glfw.swap_buffers(self.window)
        return time.monotonic_ns()

    def close(self) -> None:
        glfw.destroy_window(self.window)
        glfw.terminate()


def open_window(display: Display, size: tuple[int, int], title: str) -> WallWindow:
    """Open the wall's window as its table says (window rectangle or fullscreen on a
    monitor, vsync, stereo) with a GL 4.3 core context; ContextError says what failed."""
    if display.x_display is not None:
        os.environ["DISPLAY"] = display.x_display  # GLFW reads it when it starts
    with flushing_denormals():  # the driver's threads keep it (cavesim.gpu.gl.denormals)
        started = glfw.init()
    if not started:
        where = os.environ.get("DISPLAY") or "no DISPLAY set"
        raise ContextError(f"cannot open a window: GLFW found no display ({where})",
                           "run the node on a machine with an X server, set DISPLAY or "
                           "x_display in [wall.display], or run without windows (no "
                           "--display or --preview)")
    monitor = _monitor(display)
    width, height = display.window[2:] if display.window else size
    if display.fullscreen:
        width, height = glfw.get_video_mode(monitor).size
    stereo = display.stereo
    window = _create(width, height, title, monitor if display.fullscreen else None,
                     stereo is StereoMode.QUAD)
    if window is None and stereo is StereoMode.QUAD:
        log.warning("%s: the driver offers no quad-buffered stereo visual; showing "
                    "side-by-side frame packing instead", title)
        stereo = StereoMode.SIDE_BY_SIDE
        window = _create(width, height, title, monitor if display.fullscreen else None, False)
    if window is None:
        glfw.terminate()
        raise ContextError(f"cannot open a {width}x{height} window with OpenGL "
                           f"{REQUIRED_GL_VERSION // 100}.{REQUIRED_GL_VERSION % 100 // 10} "
                           f"core", "use a driver that offers OpenGL 4.3 core under X (Mesa "
                           "20+ or the GPU vendor's driver)")
    if not display.fullscreen:
        origin = glfw.get_monitor_pos(monitor)
        x, y = display.window[:2] if display.window else (0, 0)
        glfw.set_window_pos(window, origin[0] + x, origin[1] + y)
    glfw.make_context_current(window)
    glfw.swap_interval(1 if display.vsync else 0)
    return WallWindow(window, attach_context(glfw.get_proc_address), stereo)


def _monitor(display: Display):
    monitors = glfw.get_monitors()
    index = display.monitor or 0
    if index >= len(monitors):
        glfw.terminate()
        raise ContextError(f"monitor {index} does not exist: this display has "
                           f"{len(monitors)} monitor(s)", "set [wall.display] monitor to one "
                           "of them (0 is the primary)")
    return monitors[index]


def _create(width: int, height: int, title: str, monitor, stereo: bool):
    glfw.default_window_hints()
    glfw.window_hint(glfw.CONTEXT_VERSION_MAJOR, REQUIRED_GL_VERSION // 100)
    glfw.window_hint(glfw.CONTEXT_VERSION_MINOR, REQUIRED_GL_VERSION % 100 // 10)
    glfw.window_hint(glfw.OPENGL_PROFILE, glfw.OPENGL_CORE_PROFILE)
    glfw.window_hint(glfw.OPENGL_FORWARD_COMPAT, True)
    glfw.window_hint(glfw.STEREO, stereo)
    glfw.window_hint(glfw.RESIZABLE, False)
    with flushing_denormals():  # the driver's threads keep it (cavesim.gpu.gl.denormals)
        return glfw.create_window(width, height, title, monitor, None) or None
