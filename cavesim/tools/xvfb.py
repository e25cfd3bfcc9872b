"""A virtual X server (Xvfb) on a free display: where windows open on a machine without a
screen, for the window tests and `cavesim bench --cluster`'s swap barrier."""

from __future__ import annotations

import os
import shutil
import subprocess
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

SOCKETS = Path("/tmp/.X11-unix")
DISPLAY_NUMBERS = range(90, 200)
START_SECONDS = 10.0


class XServerError(Exception):
    """Xvfb is missing or did not start."""


@contextmanager
def virtual_display(width: int = 1280, height: int = 1024) -> Iterator[str]:
    """Xvfb on a free display (":N") with one `width` x `height` screen; DISPLAY names it
    inside the block and is restored after."""
    if shutil.which("Xvfb") is None:
        raise XServerError("Xvfb is not installed: install the Debian package xvfb "
                           "(deploy/setup.sh --test does)")
    number = next(n for n in DISPLAY_NUMBERS if not (SOCKETS / f"X{n}").exists()
                  and not Path(f"/tmp/.X{n}-lock").exists())
    display = f":{number}"
    server = subprocess.Popen(["Xvfb", display, "-screen", "0", f"{width}x{height}x24",
                               "-nolisten", "tcp"],
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + START_SECONDS
        while not (SOCKETS / f"X{number}").exists():
            if time.monotonic() > deadline or server.poll() is not None:
                raise XServerError(f"Xvfb did not start on {display} within "
                                   f"{START_SECONDS:g} s")
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
    finally:
        server.terminate()
        try:
            server.wait(timeout=10)
        except subprocess.TimeoutExpired:
            server.kill()
            server.wait()
