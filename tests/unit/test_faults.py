"""The harness's faults as text and as a plan: what `--inject` takes, and `--every-kind`'s
spread of a fault of every kind over the frames."""

from __future__ import annotations

import pytest

from nodes.arguments import fault_spec, node_fault_spec
from nodes.faults import EVERY_KIND_SPACING, KINDS, Fault, every_kind

WALLS = ("front", "left", "right")


def test_every_kind_in_1710_frames_keeps_each_fault_its_spacing():
    faults = every_kind(1710, WALLS)
    assert sorted(f.kind for f in faults) == sorted(KINDS)
    frames = [f.frame for f in faults[1:]]  # after `seed` at frame 1
    assert all(b - a >= EVERY_KIND_SPACING for a, b in zip(frames, frames[1:], strict=False))
    assert faults[-1].kind == "master-kill" and 1710 - frames[-1] >= EVERY_KIND_SPACING


def test_every_kind_says_how_many_frames_and_walls_it_needs():
    needed = len(KINDS) * EVERY_KIND_SPACING  # a gap for each kind but seed, and the new run
    with pytest.raises(ValueError, match=f"needs --frames >= {needed}, got {needed - 1}"):
        every_kind(needed - 1, WALLS)
    assert every_kind(needed, WALLS)
    with pytest.raises(ValueError, match="at least 3 walls .*need a second healthy wall"):
        every_kind(needed, ("front", "left"))


def test_a_node_takes_its_part_in_an_attack_and_the_harness_only_kinds():
    assert node_fault_spec("withhold@20") == Fault("withhold", 20)
    with pytest.raises(Exception, match="KIND one of .*colliding-source"):
        fault_spec("withhold@20")
