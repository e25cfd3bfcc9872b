"""The scene is part of the run: its digest names its content (not its path or layout), a
node's info and the master's WELCOME carry it, a wall of another scene is refused, and the
frame log's header names it for the replay."""

from __future__ import annotations

import dataclasses
import json
import logging
from pathlib import Path

import numpy as np
import pytest
from memory_walls import MemoryLink

from cavesim.core.errors import ClusterError
from cavesim.core.framelog import read_frame_log
from cavesim.core.scene import load_scene
from cavesim.core.scene.digest import _canonical, scene_digest
from cavesim.core.scene.model import Motion
from cavesim.core.wire import Command, ControlMessage, InfoMessage, decode, encode
from cavesim.tools.log_replay import scene_warnings
from nodes.master.process import MasterConfig, run_master
from tests.unit.test_scene import FULL_TOML

ROOT = Path(__file__).parents[2]
MINIMAL = ROOT / "config" / "scenes" / "minimal.toml"
WALLS = ("front", "left")
FILE_FIELD = """
[field]
kind = "file"
box_min = [0, 0, 0]
box_max = [1, 1, 1]
file = "fields/flow.npz"
"""


def digest_of(path: Path) -> str:
    return scene_digest(load_scene(path))


def test_the_digest_is_of_the_content_not_the_path_or_the_layout(tmp_path):
    copy = tmp_path / "elsewhere" / "renamed.toml"
    copy.parent.mkdir()
    copy.write_text("# a comment changes no bit\n\n" + MINIMAL.read_text().replace(" = ", "="))
    assert digest_of(copy) == digest_of(MINIMAL)
    changed = tmp_path / "changed.toml"
    changed.write_text(MINIMAL.read_text().replace("seed = 1", "seed = 2"))
    assert digest_of(changed) != digest_of(MINIMAL)


def test_an_optional_key_left_unset_leaves_the_digest_as_it_was():
    """A key a later version adds with an unset default (None) must not change the digest
    of a scene that does not use it: recorded frame logs still name their scene."""
    field = dataclasses.make_dataclass("LaterField", [("kind", str), ("added", object, None)])
    assert _canonical(field("uniform")) == _canonical(field("uniform", None)) == {
        "kind": "uniform"}
    assert _canonical(field("uniform", 1.5)) == {"kind": "uniform", "added": "1.5"}
    scene = load_scene(MINIMAL)
    assert scene.origin is None  # a key of [simulation] itself, unset
    assert scene_digest(scene) == scene_digest(dataclasses.replace(scene, origin=None))
    assert scene_digest(dataclasses.replace(scene, origin=(0.0, 0.0, 0.0))) != \
        scene_digest(scene)


def test_a_key_added_with_a_default_leaves_the_digest_as_it_was_at_that_default():
    """A particle class's `motion` came after frame logs were recorded: an inertial class
    (its default) keeps the digest the scene had before the key; a tracer class changes it.
    The digests are the ones the shipped frame logs name."""
    scene = load_scene(ROOT / "tests" / "data" / "logs" / "vortex_portable.toml")
    assert scene_digest(scene) == "213ead9e7f4e0cf5a73a285afbd35877"
    traced = dataclasses.replace(scene, particle_classes=tuple(
        dataclasses.replace(c, motion=Motion.TRACER, density=None, drag=None)
        for c in scene.particle_classes))
    assert scene_digest(traced) != scene_digest(scene)


def test_the_digest_holds_the_bytes_of_the_files_the_scene_names(tmp_path):
    scene = tmp_path / "scene.toml"
    scene.write_text(FULL_TOML.split("[field]")[0] + FILE_FIELD + "\n[collision]"
                     + FULL_TOML.split("[collision]")[1])
    (tmp_path / "fields").mkdir()
    velocity = np.zeros((6, 5, 4, 3), np.float32)
    np.savez(tmp_path / "fields" / "flow.npz", velocity=velocity)
    before = digest_of(scene)
    np.savez(tmp_path / "fields" / "flow.npz", velocity=velocity + 1)
    assert digest_of(scene) != before


def test_info_and_welcome_carry_the_scene_digest():
    digest = digest_of(MINIMAL)
    info = InfoMessage(0, "front", 0, True, "r", "v", "4.3", nonce=7, scene=digest)
    assert decode(encode(info, "s"), "s") == info
    welcome = ControlMessage(0, Command.WELCOME, "front", digest=digest, nonce=7)
    assert decode(encode(welcome, "s"), "s") == welcome


def test_a_wall_of_another_scene_is_refused_naming_both_digests(tmp_path, caplog):
    link = MemoryLink(WALLS)
    link.walls["left"].scene = "ab" * 16
    config = MasterConfig(WALLS, MINIMAL, 5, join_timeout=1.0)
    with caplog.at_level(logging.ERROR), pytest.raises(ClusterError) as raised:
        run_master(config, link)
    ours = digest_of(MINIMAL)
    line = f"wall left holds scene {'ab' * 16}, this run's scene {MINIMAL} is {ours}"
    assert "did not join" in str(raised.value) and line in str(raised.value)
    assert [r.message for r in caplog.records].count(f"master: {line}: give every host the "
                                                     f"same scene file") == 1
    welcomes = [m for m in link.sent if getattr(m, "command", None) is Command.WELCOME]
    assert {m.digest for m in welcomes} == {ours}


def test_the_frame_log_names_the_scene_digest(tmp_path):
    config = MasterConfig(WALLS, MINIMAL, 3, frame_log=tmp_path / "frames.log")
    run_master(config, MemoryLink(WALLS))
    header, frames = read_frame_log(tmp_path / "frames.log")
    assert header["scene_digest"] == digest_of(MINIMAL) and len(frames) == 3


def test_the_replay_checks_the_digest_and_says_what_it_could_not_check():
    ours, other = digest_of(MINIMAL), "cd" * 16
    assert scene_warnings(ours, ours, MINIMAL, given=False) == []
    with pytest.raises(ValueError, match=f"now holds scene {other}, the run's was {ours}: "
                                         f"give the run's scene with --scene"):
        scene_warnings(ours, other, MINIMAL, given=False)
    (warning,) = scene_warnings(ours, other, MINIMAL, given=True)
    assert "--scene overrides the check" in warning
    (warning,) = scene_warnings(None, ours, MINIMAL, given=False)
    assert "names no scene digest" in warning


def test_a_log_from_before_scene_digests_still_opens(tmp_path):
    """A shipped log with its header's digest taken out, as logs were written before."""
    for log in (ROOT / "tests" / "data" / "logs").glob("*.log"):
        data = log.read_bytes()
        end = data.index(b"\n")
        header = json.loads(data[:end])
        assert "scene_digest" in header
        del header["scene_digest"]
        old = tmp_path / log.name
        old.write_bytes(json.dumps(header).encode() + data[end:])
        opened, frames = read_frame_log(old)
        assert opened == header and len(list(frames)) == len(list(read_frame_log(log)[1]))
