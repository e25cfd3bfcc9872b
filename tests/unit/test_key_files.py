"""Key files: only their owner may read them, each is its own role's (its certificate names
the role: wall, tracker or operator), a master.key whose halves do not belong together is
named so, a preview with keys signs with an operator's key of the same session, and a local
run's member keys never land in its output folder."""

from __future__ import annotations

import argparse
import os
from pathlib import Path

import pytest

from cavesim.core.wire.credentials import (
    OPERATOR,
    ROLE_CODES,
    Identity,
    generate,
    read_card,
)
from cavesim.core.wire.key_files import read_key_file, write_key_files
from nodes import cli
from nodes.arguments import USAGE_ERROR, UsageError, network_and_key
from nodes.launch.cluster import _member_keys
from nodes.launch.launcher import LocalCluster
from nodes.master.process import MasterConfig

ROOT = Path(__file__).parents[2]
CAVE = ROOT / "config" / "cave" / "flex4.toml"


@pytest.fixture
def keys(tmp_path: Path) -> Path:
    write_key_files(tmp_path, generate(), ("front", "left"), ("dtrack",), ("desk",))
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
    ("wall-front.key", "operator", None, "wall front"),  # a wall's key is no operator's
    ("operator-desk.key", "wall", "desk", "operator desk"),  # nor an operator's a wall's
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


def test_each_certificate_names_its_role_and_a_role_it_does_not_know_is_no_card(keys):
    """The master certifies a member's role with its name and key: an operator's card says
    operator, and a card whose role byte was changed (a wall's made an operator's) neither
    parses as another role nor verifies."""
    operator = read_key_file(keys / "operator-desk.key", OPERATOR)
    wall = read_key_file(keys / "wall-front.key", "wall", "front")
    assert read_card(operator.card, 0)[0] == Identity(OPERATOR, "desk")
    assert operator.card[0] == ROLE_CODES[OPERATOR] and wall.card[0] == ROLE_CODES["wall"]
    assert read_card(bytes([max(ROLE_CODES.values()) + 1]) + wall.card[1:], 0) is None
    signature = wall.sign_as_member(b"data")  # the wall's own key: only the role differs
    assert wall.signer_of(wall.card, b"data", signature) == Identity("wall", "front")
    promoted = bytes([ROLE_CODES[OPERATOR]]) + wall.card[1:]
    assert wall.signer_of(promoted, b"data", signature) is None
    assert operator.same_session(wall) and not operator.same_session(generate())


def test_cavesim_keys_writes_an_operators_key(tmp_path, capsys):
    assert cli.main(["keys", "--out", str(tmp_path), "--walls", "front", "--operators",
                     "desk,booth"]) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "master.key", "operator-booth.key", "operator-desk.key", "wall-front.key"]
    assert read_key_file(tmp_path / "operator-booth.key", OPERATOR).member \
        == Identity(OPERATOR, "booth")
    assert "operator-desk.key" in capsys.readouterr().out
    assert cli.main(["keys", "--out", str(tmp_path), "--walls", "front", "--operators",
                     "desk,desk"]) == USAGE_ERROR
    assert "argument --operators: " in capsys.readouterr().err


def test_a_keyed_preview_needs_an_operators_key_of_its_own_session(keys, tmp_path, capsys):
    """`cavesim node --preview --key-file` without --operator-key-file, with a key of
    another session or another role there, or --operator-key-file without a preview: one
    line each, before anything starts."""
    other = tmp_path / "other"
    write_key_files(other, generate(), (), operators=("desk",))
    node = ["node", "--wall", "front", "--cave", str(CAVE), "--key-file",
            str(keys / "wall-front.key")]
    for argv, line in (
            ([*node, "--preview"], "argument --preview: with --key-file it needs "
                                   "--operator-key-file FILE too"),
            ([*node, "--preview", "--operator-key-file", str(other / "operator-desk.key")],
             "is of another session than --key-file"),
            ([*node, "--preview", "--operator-key-file", str(keys / "wall-left.key")],
             "holds the key of wall left; this needs operator left's"),
            ([*node, "--operator-key-file", str(keys / "operator-desk.key")],
             "argument --operator-key-file: only with --preview and --key-file")):
        assert cli.main(argv) == USAGE_ERROR
        err = capsys.readouterr().err
        assert line in err and err.count("\n") == 1, err


def test_a_local_runs_member_keys_are_private_and_gone_after_it(tmp_path):
    """... and a preview gets an operator's key of its own name beside its wall key."""
    config = MasterConfig(("front", "left"), Path("scene.toml"), 10, "s",
                          credentials=generate())
    with _member_keys(config, frozenset({"left"})) as folder:
        assert not folder.is_relative_to(tmp_path)
        assert os.stat(folder).st_mode & 0o077 == 0
        assert sorted(p.name for p in folder.iterdir()) == [
            "operator-left.key", "wall-front.key", "wall-left.key"]
        assert read_key_file(folder / "wall-left.key", "wall", "left").card is not None
        cluster = LocalCluster(Path("scene.toml"), tmp_path, "s", keys=folder,
                               operators=frozenset({"left"}))
        assert cluster.key_arguments("left") == [
            "--key-file", str(folder / "wall-left.key"),
            "--operator-key-file", str(folder / "operator-left.key")]
        assert cluster.key_arguments("front") == ["--key-file", str(folder / "wall-front.key")]
    assert not folder.exists()
