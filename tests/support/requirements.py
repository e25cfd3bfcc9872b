"""The outside tools some tests drive, and a pytest plugin that skips a test without them.

A test marked `@pytest.mark.requires("glslang", ...)` is skipped, with the one-line reason
`missing` gives, where a tool it names is unavailable: a GPU machine without Xvfb still
runs the rest. With `--require-tools` (deploy/test.sh passes it) such a test fails
instead, so a broken setup cannot hide behind skips; deploy/setup.sh --test installs them
all. tests/conftest.py loads this module as a plugin.
"""

from __future__ import annotations

import os
import shutil
from collections.abc import Callable
from pathlib import Path

import pytest
from netns import unavailable as netns_unavailable

from cavesim.gpu.shader_gate import VALIDATOR

ROOT = Path(__file__).parents[2]
CAVESIM = ROOT / ".venv" / "bin" / "cavesim"  # what deploy/launch.sh runs here


def _command(name: str, package: str) -> Callable[[], str | None]:
    def check() -> str | None:
        if shutil.which(name) is None:
            return f"no `{name}` command: install the Debian package {package}"
        return None
    return check


def _venv() -> str | None:
    if not os.access(CAVESIM, os.X_OK):
        return f"no {CAVESIM.relative_to(ROOT)}: run deploy/setup.sh"
    return None


REQUIREMENTS: dict[str, Callable[[], str | None]] = {
    "xvfb": _command("Xvfb", "xvfb"),  # the X server windows open on
    "xdotool": _command("xdotool", "xdotool"),  # finds, focuses and types into windows
    "glslang": _command(VALIDATOR, "glslang-tools"),  # the Khronos reference front-end
    "netns": netns_unavailable,  # root and `ip netns` (tests/support/netns.py)
    "venv": _venv,  # the project's own .venv/bin/cavesim
}


def missing(name: str) -> str | None:
    """Why requirement `name` is unavailable here (one line), or None."""
    if name not in REQUIREMENTS:
        raise ValueError(f"unknown requirement {name!r}; known: {', '.join(REQUIREMENTS)}")
    return REQUIREMENTS[name]()


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.addoption("--require-tools", action="store_true",
                     help="fail, rather than skip, a test whose outside tool is missing "
                          f"(requires(...): {', '.join(REQUIREMENTS)})")


@pytest.hookimpl(wrapper=True)  # ahead of pytest's own skip marks: a skip names the test
def pytest_runtest_setup(item: pytest.Item):
    for marker in item.iter_markers("requires"):
        for reason in filter(None, map(missing, marker.args)):
            if item.config.getoption("require_tools"):
                pytest.fail(f"--require-tools: {reason}; deploy/setup.sh --test installs "
                            f"every test tool", pytrace=False)
            item.add_marker(pytest.mark.skip(reason=reason))
    return (yield)
