"""A real X server for the window tests: Xvfb on a free display, and what a person (or a
window manager) does to windows on it: find one by its title, focus it, hold a key, close
it the way a window manager's close button does (a WM_DELETE_WINDOW message)."""

from __future__ import annotations

import ctypes
import ctypes.util
import subprocess
import time
from contextlib import ExitStack

import pytest

from cavesim.tools.xvfb import XServerError, virtual_display


@pytest.fixture(scope="module")
def xserver():
    """An Xvfb display (":N") for the module's tests; DISPLAY names it while they run.
    A test using it is marked `requires("xvfb")`, and `requires("xdotool")` as well when it
    calls the functions below (tests/support/requirements.py)."""
    with ExitStack() as stack:
        try:
            display = stack.enter_context(virtual_display())
        except XServerError as e:
            pytest.fail(str(e))
        yield display


def xdotool(*args: str) -> str:
    done = subprocess.run(["xdotool", *args], capture_output=True, text=True, timeout=10)
    return done.stdout.strip()


def window_id(title: str, timeout: float = 30.0) -> int:
    """The X window whose title is `title` (or `title - ...`: the preview's says its frame
    after it), once it is there."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        found = xdotool("search", "--name", f"^{title}( - .*)?$").split()
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
