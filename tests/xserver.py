"""A real X server for the window tests: Xvfb on a free display, and what a person (or a
window manager) does to windows on it: find one by its title, focus it, hold a key, close
it the way a window manager's close button does (a WM_DELETE_WINDOW message)."""

from __future__ import annotations

import ctypes
import ctypes.util
import os
import shutil
import subprocess
import time
from pathlib import Path

import pytest

SOCKETS = Path("/tmp/.X11-unix")
START_SECONDS = 10.0


@pytest.fixture(scope="module")
def xserver():
    """An Xvfb display (":N") for the module's tests; DISPLAY names it while they run."""
    if shutil.which("Xvfb") is None or shutil.which("xdotool") is None:
        pytest.fail("the window tests need Xvfb and xdotool: deploy/setup.sh --test installs "
                    "the Debian packages xvfb and xdotool")
    number = next(n for n in range(90, 200) if not (SOCKETS / f"X{n}").exists()
                  and not Path(f"/tmp/.X{n}-lock").exists())
    display = f":{number}"
    server = subprocess.Popen(["Xvfb", display, "-screen", "0", "1280x1024x24", "-nolisten",
                               "tcp"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + START_SECONDS
    while not (SOCKETS / f"X{number}").exists():
        if time.monotonic() > deadline or server.poll() is not None:
            server.kill()
            pytest.fail(f"Xvfb did not start on {display}")
        time.sleep(0.05)
    saved = os.environ.get("DISPLAY")
    os.environ["DISPLAY"] = display
    try:
        yield display
    finally:
        if saved is None:
            os.environ.pop("DISPLAY", None)
        else:
            os.environ["DISPLAY"] = saved
        server.terminate()
        server.wait(timeout=10)


def xdotool(*args: str) -> str:
    done = subprocess.run(["xdotool", *args], capture_output=True, text=True, timeout=10)
    return done.stdout.strip()


def window_id(title: str, timeout: float = 30.0) -> int:
    """The X window whose title is `title`, once it is there."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        found = xdotool("search", "--name", f"^{title}$").split()
        if found:
            return int(found[0])
        time.sleep(0.1)
    raise AssertionError(f"no window titled {title!r} appeared within {timeout} s")


def hold_key(window: int, key: str, seconds: float) -> None:
    """Focus `window` and hold `key` down for `seconds` (XTest: as a keyboard would)."""
    xdotool("windowfocus", "--sync", str(window))
    xdotool("keydown", key)
    time.sleep(seconds)
    xdotool("keyup", key)


class _ClientMessage(ctypes.Structure):
    _fields_ = [("type", ctypes.c_int), ("serial", ctypes.c_ulong), ("send_event", ctypes.c_int),
                ("display", ctypes.c_void_p), ("window", ctypes.c_ulong),
                ("message_type", ctypes.c_ulong), ("format", ctypes.c_int),
                ("data", ctypes.c_long * 5)]


class _Event(ctypes.Union):
    _fields_ = [("client", _ClientMessage), ("pad", ctypes.c_long * 24)]


def close_window(window: int) -> None:
    """Ask `window` to close as a window manager's close button does (WM_DELETE_WINDOW)."""
    x11 = ctypes.CDLL(ctypes.util.find_library("X11"))
    x11.XOpenDisplay.restype = ctypes.c_void_p
    x11.XInternAtom.restype = ctypes.c_ulong
    x11.XInternAtom.argtypes = [ctypes.c_void_p, ctypes.c_char_p, ctypes.c_int]
    x11.XSendEvent.argtypes = [ctypes.c_void_p, ctypes.c_ulong, ctypes.c_int, ctypes.c_long,
                               ctypes.POINTER(_Event)]
    x11.XFlush.argtypes = x11.XCloseDisplay.argtypes = [ctypes.c_void_p]
    display = x11.XOpenDisplay(None)
    event = _Event()
    client = event.client
    client.type, client.send_event, client.display, client.window = 33, 1, display, window
    client.message_type = x11.XInternAtom(display, b"WM_PROTOCOLS", False)
    client.format = 32
    client.data[0] = x11.XInternAtom(display, b"WM_DELETE_WINDOW", False)
    x11.XSendEvent(display, window, False, 0, ctypes.byref(event))
    x11.XFlush(display)
    x11.XCloseDisplay(display)
