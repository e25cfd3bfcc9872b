"""tests/support/requirements.py: a missing outside tool skips the tests that need it, with its
reason, and `--require-tools` (deploy/test.sh) turns that skip into a failure."""

import pytest
from requirements import REQUIREMENTS, missing

pytest_plugins = ["pytester"]

NEEDS_GLSLANG = """
import pytest

@pytest.mark.requires("glslang")
def test_front_end():
    pass
"""


@pytest.fixture
def bare_machine(monkeypatch):
    """No command on the PATH, as on a machine without the test packages."""
    monkeypatch.setenv("PATH", "")


def run_needs_glslang(pytester, *args: str) -> pytest.RunResult:
    """A test that needs glslangValidator, run in its own pytest session with the plugin."""
    pytester.makepyfile(NEEDS_GLSLANG)
    # without hypothesis' plugin: its end-of-run summary imports for a second per session
    return pytester.runpytest("-p", "no:hypothesispytest", "-p", "requirements", *args)


def test_every_missing_command_is_named_with_its_package(bare_machine):
    assert missing("glslang") == ("no `glslangValidator` command: install the Debian package "
                                  "glslang-tools")
    assert missing("xvfb") == "no `Xvfb` command: install the Debian package xvfb"
    assert missing("xdotool") == "no `xdotool` command: install the Debian package xdotool"


def test_an_unknown_requirement_is_refused():
    with pytest.raises(ValueError, match=r"unknown requirement 'glslng'; known: xvfb, "):
        missing("glslng")
    assert set(REQUIREMENTS) == {"xvfb", "xdotool", "glslang", "netns", "venv"}


def test_a_missing_tool_skips_with_its_reason(bare_machine, pytester):
    result = run_needs_glslang(pytester, "-rs")
    result.assert_outcomes(skipped=1)
    result.stdout.fnmatch_lines(["SKIPPED * no `glslangValidator` command: install the Debian "
                                 "package glslang-tools"])


def test_a_tool_on_the_path_runs_the_test(monkeypatch, tmp_path, pytester):
    validator = tmp_path / "glslangValidator"
    validator.write_text("#!/bin/sh\n")
    validator.chmod(0o755)
    monkeypatch.setenv("PATH", str(tmp_path))
    assert missing("glslang") is None
    run_needs_glslang(pytester, "--require-tools").assert_outcomes(passed=1)


def test_with_require_tools_a_missing_tool_fails(bare_machine, pytester):
    result = run_needs_glslang(pytester, "--require-tools")
    result.assert_outcomes(errors=1)
    result.stdout.fnmatch_lines(["*--require-tools: no `glslangValidator` command: install the "
                                 "Debian package glslang-tools; deploy/setup.sh --test installs "
                                 "every test tool"])
