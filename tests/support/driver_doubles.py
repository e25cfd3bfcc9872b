"""A recorded driver in place of this machine's: it answers cavesim's EGL and GL questions
(`cavesim.gpu.gl.driver.Driver`) from a profile in tests/data/drivers/.

A profile holds what one driver answered: its client extensions, each device's extensions
and DRM files, and the context it gave when asked for a GL version ("330": what an opener
that asks nothing gets from moderngl, "430": what cavesim asks for), with the strings and
limits of that context. A driver a user reports is one more file: doctor.json holds the
same answers.
"""

from __future__ import annotations

import json
from pathlib import Path

from cavesim.gpu.gl.devices import (
    EGL_DRM_DEVICE_FILE_EXT,
    EGL_DRM_RENDER_NODE_FILE_EXT,
    EGL_RENDERER_EXT,
)
from cavesim.gpu.gl.driver import EGL_EXTENSIONS, REQUIRED_GL_VERSION

PROFILES = Path(__file__).parents[1] / "data" / "drivers"
_DEVICE_FIELDS = {EGL_DRM_DEVICE_FILE_EXT: "drm_file", EGL_DRM_RENDER_NODE_FILE_EXT: "render_node",
                  EGL_RENDERER_EXT: "name"}


def profile_names() -> list[str]:
    return sorted(path.stem for path in PROFILES.glob("*.json"))


def load_profile(name: str) -> dict:
    return json.loads((PROFILES / f"{name}.json").read_text())


class RecordedContext:
    """The context a profile's driver gave: its version, strings and limits; nothing runs."""

    def __init__(self, answers: dict) -> None:
        self.version_code = answers["version_code"]
        self.info = {name: tuple(value) if isinstance(value, list) else value
                     for name, value in answers.items() if name != "version_code"}
        self.error = "GL_NO_ERROR"
        self.released = False
        self.extra = None

    def simple_framebuffer(self, size: tuple[int, int]) -> RecordedFramebuffer:
        return RecordedFramebuffer()

    def release(self) -> None:
        self.released = True


class RecordedFramebuffer:
    def use(self) -> None:
        pass


class RecordedDriver:
    """`Driver` answered from a profile, with the context its driver gives when asked for
    4.3 (the only version cavesim's openers ask for); `opened` counts the contexts."""

    def __init__(self, profile: dict) -> None:
        self.profile = profile
        self.opened = 0

    def client_extensions(self) -> str:
        return self.profile["egl"]["client_extensions"]

    def device_handles(self) -> list[int]:
        return list(range(len(self.profile["egl"]["devices"])))

    def device_string(self, handle: int, name: int) -> str | None:
        device = self.profile["egl"]["devices"][handle]
        if name == EGL_EXTENSIONS:
            return " ".join(device["extensions"])
        return device[_DEVICE_FIELDS[name]]

    def open_context(self, device_index: int) -> RecordedContext:
        self.opened += 1
        asked = self.profile["contexts"][device_index]["asked"]
        return RecordedContext(asked[str(REQUIRED_GL_VERSION)])
