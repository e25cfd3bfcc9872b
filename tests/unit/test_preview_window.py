"""The preview window's pure parts: one key table gives the moves, the session requests and
the help line; a press of a request key changes the session controls as documented; the
title tells the frame and the frame rate a few times a second."""

from __future__ import annotations

import glfw

from cavesim.core.wire import SessionControls
from nodes.wall.preview_controls import ASKS, BINDINGS, MOVES, help_line, key_name, pressed
from nodes.wall.title import FrameRate


def test_every_bound_key_is_one_thing_and_named_in_the_help_line():
    keys = [key for _, group in BINDINGS for key in group]
    assert len(keys) == len(set(keys)) == len(MOVES) + len(ASKS)
    line = help_line()
    for group, bound in BINDINGS:
        assert f"{'/'.join(key_name(k) for k in bound)} {group}" in line
    assert "P pause" in line and "R reset" in line and "Esc quit" in line
    assert ASKS == {glfw.KEY_P: "pause", glfw.KEY_R: "reset", glfw.KEY_ESCAPE: "quit"}
    assert MOVES[glfw.KEY_T] == ("tilt", 0, 1) and line.isascii()


def test_pause_toggles_reset_counts_and_quit_holds():
    controls = pressed(None, "pause")
    assert controls == SessionControls(paused=True)
    controls = pressed(pressed(controls, "reset"), "reset")
    assert controls == SessionControls(paused=True, resets=2)
    controls = pressed(controls, "pause")
    assert controls == SessionControls(resets=2)
    assert pressed(pressed(controls, "quit"), "pause") == SessionControls(True, 2, True)


def test_the_title_says_frame_and_rate_every_half_second():
    rate = FrameRate("cavesim preview", every=0.5)
    assert rate.title(1, 10.0, False) == "cavesim preview - frame 1"
    assert rate.title(20, 10.4, False) is None
    assert rate.title(31, 10.5, False) == "cavesim preview - frame 31 - 60.0 frames/s"
    assert rate.title(61, 11.0, True) == "cavesim preview - frame 61 - 60.0 frames/s - paused"


def test_the_guide_names_every_bound_key():
    """The live-walls guide's table of keys follows BINDINGS: a key rebound is a key the
    guide must name."""
    from pathlib import Path

    guide = (Path(__file__).parents[2] / "docs/guide/live-walls.md").read_text()
    table = guide.split("| keys | what they do |", 1)[1].split("\n\n", 1)[0]
    cells = {cell for row in table.splitlines()[2:] for cell in
             row.split("|")[1].replace(",", "/").replace(" ", "").split("/")}
    assert cells == {key_name(key) for _, keys in BINDINGS for key in keys}
