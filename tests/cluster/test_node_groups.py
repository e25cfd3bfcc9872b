"""A node of several walls: it steps the particles once a frame and draws each of its
walls, and a CAVE run on such nodes holds and shows the same bytes as one node per wall."""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).parents[2]
DUST_DEVIL = ROOT / "config" / "scenes" / "dust_devil.toml"
FLEX4 = ROOT / "config" / "cave" / "flex4.toml"
WALLS = ("front", "left", "right", "floor")

pytestmark = pytest.mark.slow


def grouped_cave(folder: Path, nodes: dict[str, str]) -> Path:
    """flex4 with each wall of `nodes` drawn by the node it names."""
    text = FLEX4.read_text()
    for wall, node in nodes.items():
        text = text.replace(f'name = "{wall}"\n', f'name = "{wall}"\nnode = "{node}"\n', 1)
    path = folder / "grouped.toml"
    path.write_text(text)
    return path


def run(folder: Path, cave: Path, *flags: str) -> dict:
    command = [sys.executable, "-m", "cavesim", "run", "--cave", str(cave), "--scene",
               str(DUST_DEVIL), "--frames", "40", "--render-every", "20", "--out", str(folder),
               "--session", f"groups{os.getpid()}", *flags]  # one session: the same frames
    result = subprocess.run(command, capture_output=True, text=True, timeout=300, cwd=ROOT)
    assert result.returncode == 0, result.stdout + result.stderr
    return json.loads((folder / "report.json").read_text())


def records(folder: Path) -> bytes:
    """The frame log after its header (which names the members): each frame's inputs and
    the checksum the cluster agreed on."""
    return (folder / "frames.log").read_bytes().split(b"\n", 1)[1]


def test_four_walls_on_two_nodes_match_four_single_wall_nodes_byte_for_byte(tmp_path):
    cave = grouped_cave(tmp_path, {"front": "solo", "left": "ws2", "right": "ws2",
                                   "floor": "ws2"})
    nodes = {"grouped": run(tmp_path / "grouped", cave),
             "by_gpu": run(tmp_path / "by_gpu", cave, "--group-by", "gpu"),
             "single": run(tmp_path / "single", cave, "--group-by", "wall")}
    assert nodes["grouped"]["walls_of_nodes"] == {"solo": ["front"],
                                                  "ws2": ["left", "right", "floor"]}
    assert nodes["by_gpu"]["walls_of_nodes"] == {"gpu0": list(WALLS)}  # llvmpipe: one device
    assert nodes["single"]["nodes"] == list(WALLS)
    for name, report in nodes.items():
        assert report["frames"] == 40 and report["divergences"] == [], name
        assert report["final"]["agree"], name
        assert report["images"]["composites"] == 2, name
    for name in ("grouped", "by_gpu"):
        assert records(tmp_path / name) == records(tmp_path / "single"), name
        for wall in WALLS:
            for k in (20, 40):
                picture = Path("walls", wall, f"frame_{k:06d}.png")
                assert (tmp_path / name / picture).read_bytes() == \
                    (tmp_path / "single" / picture).read_bytes(), (name, str(picture))


def test_a_grouped_node_that_diverges_is_found_and_healed_for_all_its_walls(tmp_path):
    """The check harness on a CAVE of three nodes: a bit flipped in the node of two walls."""
    cave = grouped_cave(tmp_path, {"right": "ws2", "floor": "ws2"})
    command = [sys.executable, "-m", "cavesim", "check", "--cave", str(cave), "--frames", "60",
               "--inject", "bitflip@20:ws2", "--out", str(tmp_path / "check"),
               "--session", f"groupcheck{os.getpid()}"]
    result = subprocess.run(command, capture_output=True, text=True, timeout=300, cwd=ROOT)
    assert result.returncode == 0, result.stdout + result.stderr
    report = json.loads((tmp_path / "check" / "check.json").read_text())
    (outcome,) = report["faults"]
    assert outcome["fault"] == "bitflip@20:ws2" and outcome["named"] == ["ws2"]
    assert outcome["detected_frame"] == 20 and outcome["healed"]
    assert outcome["localisation"]["exact"]
    assert report["run"]["walls_of_nodes"] == {"front": ["front"], "left": ["left"],
                                               "ws2": ["right", "floor"]}
