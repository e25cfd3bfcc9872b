"""Key files: only their owner may read them, each is its own role's, a master.key whose
halves do not belong together is named so, and a local run's wall keys never land in its
output folder."""

from __future__ import annotations

import argparse
import os
from pathlib import Path

import pytest

from cavesim.core.wire.credentials import generate
from cavesim.core.wire.key_files import read_key_file, write_key_files
from nodes.arguments import UsageError, network_and_key
from nodes.launch.cluster import _wall_keys
from nodes.master.process import MasterConfig


@pytest.fixture
def keys(tmp_path: Path) -> Path:
    write_key_files(tmp_path, generate(), ("front", "left"), ("dtrack",))
    return tmp_path


def node_args(key_file: Path) -> argparse.Namespace:
    return argparse.Namespace(listen=[], connect=[], zenoh_config=None, key_file=key_file)


def test_a_key_file_others_may_read_is_refused_with_the_chmod_to_run(keys):
    path = keys / "wall-front.key"
    os.chmod(path, 0o644)
    with pytest.raises(ValueError, match=rf"mode 0644.*run `chmod 600 {path}`"):
        read_key_file(path, "wall", "front")


@pytest.mark.parametrize("given, role, name, held", [
    ("master.key", "wall", "front", "master"),  # a node given the master's key
    ("wall-left.key", "wall", "front", "wall left"),  # another wall's key
    ("tracker-dtrack.key", "master", None, "tracker dtrack"),
])
def test_a_key_of_another_role_or_member_is_refused(keys, given, role, name, held):
    with pytest.raises(UsageError, match=f"holds the key of {held}; this needs"):
        network_and_key(node_args(keys / given), "node", role, name)


def test_a_master_key_with_halves_of_two_key_sets_is_named_so(keys):
    other = keys / "other"
    write_key_files(other, generate(), ())
    path = keys / "master.key"
    mine = path.read_text().splitlines()
    theirs = (other / "master.key").read_text().splitlines()
    path.write_text("\n".join(t if t.startswith("master_public") else m
                              for m, t in zip(mine, theirs, strict=True)) + "\n")
    with pytest.raises(ValueError, match="halves do not belong together.*two key sets"):
        read_key_file(path, "master")


def test_a_local_runs_wall_keys_are_private_and_gone_after_it(tmp_path):
    config = MasterConfig(("front", "left"), Path("scene.toml"), 10, "s",
                          credentials=generate())
    with _wall_keys(config) as folder:
        assert not folder.is_relative_to(tmp_path)
        assert os.stat(folder).st_mode & 0o077 == 0
        assert sorted(p.name for p in folder.iterdir()) == ["wall-front.key", "wall-left.key"]
        assert read_key_file(folder / "wall-left.key", "wall", "left").card is not None
    assert not folder.exists()
