"""A node started with another scene than the master's is refused with one line on both
sides, naming both scene digests, before any frame is stepped (real processes)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from master_process import spawn_master

from cavesim.core.scene import load_scene
from cavesim.core.scene.digest import scene_digest
from nodes.launch.launcher import LocalCluster

ROOT = Path(__file__).parents[2]
MINIMAL = ROOT / "config" / "scenes" / "minimal.toml"

pytestmark = pytest.mark.slow


def test_a_node_of_another_scene_is_refused_on_both_sides(tmp_path):
    other = tmp_path / "other.toml"
    other.write_text(MINIMAL.read_text().replace("seed = 1", "seed = 2"))
    ours, theirs = scene_digest(load_scene(MINIMAL)), scene_digest(load_scene(other))
    with LocalCluster(MINIMAL, tmp_path, f"scene{os.getpid()}") as cluster:
        cluster.start_node("front", extra=("--scene", str(other), "--master-wait", "60"))
        master = spawn_master(cluster, ("front",), 10, ("--join-timeout", "20"))
        node_exit = cluster.nodes["front"].wait(timeout=120)
        assert master.wait(timeout=120) == 1
    node_log = cluster.log_path("front").read_text()
    assert node_exit == 1 and "Traceback" not in node_log
    node_line = node_log.strip().splitlines()[-1]
    assert f"is of scene {ours}, this node's --scene {other} is {theirs}" in node_line
    master_line = (tmp_path / "logs" / "master.log").read_text().strip().splitlines()[-1]
    assert f"wall front holds scene {theirs}, this run's scene {MINIMAL} is {ours}" \
        in master_line
