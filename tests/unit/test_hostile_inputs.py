"""Hostile input files get one line naming the file, what it is and what is allowed, before
anything of them is read: what a frame log's header names (`cavesim replay`, `cavesim
render`) and what a scene names (field, height field, model) must be regular files within
their limits; a field's snapshots, a glTF's nodes, nesting and buffers, a frame log's header
and an .npz's .npy headers are checked first. Every hostile file is made here, small (a
large one is sparse, or a limit is lowered)."""

from __future__ import annotations

import base64
import json
import os
import re
import struct
import threading
import zipfile
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from scenes import scene_dict

from cavesim.core.errors import FieldError, ModelError, SceneError
from cavesim.core.fields.grid import build_series
from cavesim.core.fields.heights import load_heightfield
from cavesim.core.frame import FrameInput
from cavesim.core.framelog import FrameLogError, FrameLogWriter, read_frame_log
from cavesim.core.limits import (
    MAX_FIELD_FILE_BYTES,
    MAX_FIELD_SERIES_NODES,
    MAX_FIELD_SNAPSHOTS,
    MAX_MODEL_NODES,
    MAX_NESTING,
    MAX_TOML_BYTES,
)
from cavesim.core.scene import load_scene, parse_scene
from cavesim.core.wire import FrameMessage
from cavesim.gpu.render import gltf_file
from cavesim.gpu.render.gltf_model import read_model
from cavesim.tools.log_replay import planned_run
from nodes import cli
from nodes.arguments import USAGE_ERROR

ONLY_REGULAR = "only a regular file of at most"
BLOCKED_BOUND = 30.0  # s: refusing takes milliseconds; only a reader a FIFO blocks gets here
DEEP = 2000  # levels: past Python's recursion in json and numpy's header parser alike

SCENE = """
[simulation]
capacity = 100
seed = 1

[[particle_class]]
name = "dust"
diameter = 1e-4
density = 2650.0

[forces]
gravity = [0.0, 0.0, -9.81]
"""
NAMED = {  # a scene's table naming a file, by the key that names it
    "field.file": ('[forces.drag]\n[field]\nkind = "file"\nfile = "{}"\n'
                   "box_min = [0.0, 0.0, 0.0]\nbox_max = [1.0, 1.0, 1.0]\n", "flow.npz"),
    "collision.file": ('[collision]\nkind = "heightfield"\nfile = "{}"\n', "ground.npz"),
    "helicopter.model": ("[helicopter]\nmass = 1000.0\nrotor_radius = 5.0\nhub_height = 1.3\n"
                         'model = "{}"\n', "heli.glb"),
}


# -- making hostile files ------------------------------------------------------------------

def fifo(path: Path) -> Path:
    os.mkfifo(path)
    return path


def link_to_zero(path: Path) -> Path:
    path.symlink_to("/dev/zero")
    return path


def folder(path: Path) -> Path:
    path.mkdir()
    return path


NOT_REGULAR: dict[str, tuple[Callable[[Path], Path], str]] = {
    "fifo": (fifo, "is a FIFO (named pipe)"),
    "dev-zero": (lambda path: Path("/dev/zero"), "is a character device"),
    "symlink-to-device": (link_to_zero, "is a symlink to a character device"),
    "folder": (folder, "is a folder"),
}


def scene_file(folder_: Path, named: str | None = None, target: str = "") -> Path:
    """A scene file in `folder_`, naming `target` at the key `named` (none: no file)."""
    text = SCENE + (NAMED[named][0].format(target) if named else "")
    path = folder_ / "scene.toml"
    path.write_text(text)
    return path


def frame_log(path: Path, scene: str | Path | int, header: bytes | None = None) -> Path:
    """A frame log of one frame whose header names `scene` (or is `header` itself)."""
    writer = FrameLogWriter(path, {"session": "t", "scene": str(scene)})
    writer.append(FrameMessage(1, FrameInput(1 / 60, np.eye(3))), "0" * 32, 1)
    writer.close()
    if header is not None:
        data = path.read_bytes()
        path.write_bytes(header + data[data.index(b"\n"):])
    return path


def npy_member(header: bytes, data: bytes = b"") -> bytes:
    """A version 1.0 .npy file with this header text, padded as numpy pads it."""
    padded = header + b" " * (-(10 + len(header) + 1) % 64) + b"\n"
    return b"\x93NUMPY\x01\x00" + struct.pack("<H", len(padded)) + padded + data


def npz(path: Path, **members: bytes) -> Path:
    with zipfile.ZipFile(path, "w") as archive:
        for name, content in members.items():
            archive.writestr(f"{name}.npy", content)
    return path


def chain_gltf(path: Path, nodes: int) -> Path:
    """A .gltf of one triangle at the end of a chain of `nodes` nodes."""
    triangle = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], "<f4").tobytes()
    chain = [{"children": [k + 1]} for k in range(nodes - 1)] + [{"mesh": 0}]
    return gltf_json(path, {"nodes": chain, "buffers": [{"byteLength": 36, "uri": (
        "data:application/octet-stream;base64," + base64.b64encode(triangle).decode())}]})


def gltf_json(path: Path, document: dict) -> Path:
    """A .gltf: `document` over one triangle mesh whose buffer `document` gives."""
    base = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}],
            "nodes": [{"mesh": 0}],
            "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
            "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3,
                           "type": "VEC3"}],
            "bufferViews": [{"buffer": 0, "byteLength": 36}]}
    path.write_text(json.dumps({**base, **document}))
    return path


def within_bound(call: Callable[[], object], blocking: Path | None = None) -> object:
    """`call()`; should it still be reading `blocking` (a FIFO with no writer) after
    BLOCKED_BOUND, the FIFO is given a writer that closes at once, and the test fails."""
    done: dict[str, object] = {}

    def run() -> None:
        try:
            done["value"] = call()
        except BaseException as e:  # noqa: BLE001 - raised again in the test's thread
            done["error"] = e

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    thread.join(BLOCKED_BOUND)
    if thread.is_alive():
        if blocking is not None:
            os.close(os.open(blocking, os.O_WRONLY | os.O_NONBLOCK))
        thread.join(BLOCKED_BOUND)
        pytest.fail(f"still reading {blocking} after {BLOCKED_BOUND:g} s")
    if "error" in done:
        raise done["error"]
    return done.get("value")


def one_line(capsys) -> str:
    (line,) = capsys.readouterr().err.splitlines()
    return line


# -- finding: replay and render open whatever a frame log's header names --------------------

@pytest.mark.parametrize("command", ["replay", "render"])
@pytest.mark.parametrize("kind", NOT_REGULAR)
def test_a_scene_a_log_names_that_is_no_regular_file_is_one_line(tmp_path, capsys, command,
                                                                  kind):
    make, what = NOT_REGULAR[kind]
    scene = make(tmp_path / "scene.toml")
    log = frame_log(tmp_path / "frames.log", scene)
    code = within_bound(lambda: cli.main([command, str(log)]), scene)
    assert code == USAGE_ERROR
    line = one_line(capsys)
    assert f"{scene}: scene file {what}; {ONLY_REGULAR} 16,777,216 bytes" in line, line


@pytest.mark.parametrize("named", NAMED)
@pytest.mark.parametrize("kind", [k for k in NOT_REGULAR if k != "dev-zero"])  # a device by
# its own name is no .glb: the symlink is one by a name each key takes
def test_a_file_the_logs_scene_names_that_is_no_regular_file_is_one_line(tmp_path, capsys,
                                                                        named, kind):
    make, what = NOT_REGULAR[kind]
    target = make(tmp_path / NAMED[named][1])
    log = frame_log(tmp_path / "frames.log", scene_file(tmp_path, named, str(target)))
    code = within_bound(lambda: cli.main(["replay", str(log)]), target)
    assert code == USAGE_ERROR
    line = one_line(capsys)
    assert f"{named} = {str(target)!r} is not allowed: must be a non-empty string naming an " \
           f"existing file" in line and f"(looked for {target}, which {what})" in line, line


def test_a_field_file_over_its_limit_is_refused_before_it_is_read(tmp_path):
    flow = tmp_path / "flow.npz"
    with open(flow, "wb") as file:
        file.truncate(MAX_FIELD_FILE_BYTES + 1)  # sparse: nothing is written
    with pytest.raises(SceneError, match=re.escape(
            f"{flow}: the .npz archive is 2,147,483,649 bytes (2 GiB); at most 2,147,483,648 "
            f"bytes (2 GiB) is read")):
        load_scene(scene_file(tmp_path, "field.file", flow.name))


def test_a_fifo_swapped_in_after_the_check_neither_blocks_nor_is_read(tmp_path, monkeypatch):
    regular, swapped = scene_file(tmp_path), fifo(tmp_path / "swapped.toml")
    stat = os.stat
    monkeypatch.setattr(os, "stat", lambda path, *args, **kwargs: stat(
        regular if Path(path) == swapped else path, *args, **kwargs))  # checked: regular
    with pytest.raises(SceneError, match=re.escape(f"{swapped}: scene file is a FIFO")):
        within_bound(lambda: load_scene(swapped), swapped)


def test_a_log_that_is_no_regular_file_is_one_line(tmp_path, capsys):
    log = fifo(tmp_path / "frames.log")
    assert within_bound(lambda: cli.main(["replay", str(log)]), log) == USAGE_ERROR
    assert f"{log}: the frame log is a FIFO (named pipe); {ONLY_REGULAR}" in one_line(capsys)


def test_a_scene_over_its_limit_is_refused_before_it_is_read(tmp_path, capsys):
    scene = tmp_path / "scene.toml"
    with open(scene, "wb") as file:
        file.truncate(MAX_TOML_BYTES + 1)  # sparse: nothing is written
    assert cli.main(["replay", str(frame_log(tmp_path / "frames.log", scene))]) == USAGE_ERROR
    assert (f"{scene}: scene file is 16,777,217 bytes (16 MiB); at most 16,777,216 bytes "
            f"(16 MiB) is read") in one_line(capsys)


def test_a_log_over_its_limit_is_refused_before_it_is_read(tmp_path, monkeypatch):
    from cavesim.core.framelog import log_file

    log = frame_log(tmp_path / "frames.log", scene_file(tmp_path))
    monkeypatch.setattr(log_file, "MAX_FRAME_LOG_BYTES", log.stat().st_size - 1)
    with pytest.raises(FrameLogError, match=f"{log}: the frame log is {log.stat().st_size} "
                                            f"bytes; at most {log.stat().st_size - 1} bytes"):
        read_frame_log(log)


@pytest.mark.parametrize("scene", [12, ""], ids=["a number", "empty"])
def test_a_header_naming_no_scene_file_is_one_line(tmp_path, capsys, scene):
    log = frame_log(tmp_path / "frames.log", "", header=json.dumps(
        {"format": "cavesim-frame-log", "version": 4, "session": "t", "scene": scene}).encode())
    assert cli.main(["replay", str(log)]) == USAGE_ERROR
    assert f"its header names no scene file (scene = {scene!r}" in one_line(capsys)


@pytest.mark.parametrize("planned", [{"frames": "600", "dt": 1 / 60},
                                     {"frames": 600, "dt": float("nan")},
                                     {"frames": 0, "dt": 1 / 60}], ids=["text", "nan", "none"])
def test_a_header_planning_no_run_is_refused_by_a_replay_of_trajectories(planned):
    with pytest.raises(ValueError, match="its header plans frames = .*; expected an integer "
                                         ">= 1 and a number of seconds > 0"):
        planned_run({"format": "cavesim-frame-log", "version": 4, **planned}, [])


# -- finding: the four internal errors ------------------------------------------------------

def test_a_deeply_nested_frame_log_header_is_one_line(tmp_path, capsys):
    log = frame_log(tmp_path / "frames.log", "", header=b'{"a": ' + b"[" * DEEP + b"]" * DEEP
                    + b"}")
    assert cli.main(["replay", str(log)]) == USAGE_ERROR
    assert (f"{log}: not a cavesim frame log: its header line nested deeper than "
            f"{MAX_NESTING} levels") in one_line(capsys)


def test_a_deeply_nested_gltf_is_one_line(tmp_path):
    path = tmp_path / "deep.gltf"
    path.write_text('{"asset": {"version": "2.0"}, "extras": ' + "[" * DEEP + "]" * DEEP + "}")
    with pytest.raises(ModelError, match=f"{path}: its glTF JSON nested deeper than "
                                         f"{MAX_NESTING} levels"):
        read_model(path)


MALFORMED_HEADERS = {  # .npy header texts numpy's parser fails on, each its own way
    "truncated": b"{'descr': '<f4', 'fortran_order': False,",
    "nested": b"{'descr': '<f4', 'fortran_order': False, 'shape': " + b"(" * 500 + b")" * 500
              + b"}",
    "not a dict": b"[1, 2]",
    "a huge length": b"{'descr': '<f4', 'fortran_order': False, 'shape': (10" + b"0" * 30
                     + b", 2, 2, 3)}",
}


@pytest.mark.parametrize("header", MALFORMED_HEADERS.values(), ids=MALFORMED_HEADERS)
def test_an_npz_whose_npy_header_is_malformed_is_one_line(tmp_path, header):
    flow = npz(tmp_path / "flow.npz", velocity=npy_member(header))
    with pytest.raises(SceneError) as raised:
        load_scene(scene_file(tmp_path, "field.file", flow.name))
    line = str(raised.value)
    assert "\n" not in line and len(line) < 1000, line
    assert f"{flow}: array 'velocity'" in line, line
    corner = npy_member(b"{'descr': '<f8', 'fortran_order': False, 'shape': (2,)}", bytes(16))
    ground = npz(tmp_path / "ground.npz", height=npy_member(header), box_min=corner,
                 box_max=corner)
    with pytest.raises(FieldError, match=f"{ground}: array 'height'"):
        load_heightfield(ground)


# -- finding: a field of a million snapshots passes validation ------------------------------

def series_npz(path: Path, snapshots: int) -> Path:
    np.savez_compressed(path, velocity=np.zeros((snapshots, 2, 2, 2, 3), np.float32),
                        times=np.arange(snapshots, dtype=np.float64))
    return path


def test_an_npz_series_past_the_snapshot_limit_is_refused_naming_it(tmp_path):
    series_npz(tmp_path / "flow.npz", MAX_FIELD_SNAPSHOTS)
    scene = scene_file(tmp_path, "field.file", "flow.npz")
    assert len(load_scene(scene).field.times) == MAX_FIELD_SNAPSHOTS  # at the limit: read
    series_npz(tmp_path / "flow.npz", MAX_FIELD_SNAPSHOTS + 1)
    with pytest.raises(SceneError, match=f"holds {MAX_FIELD_SNAPSHOTS + 1:,} snapshots; at "
                                         f"most MAX_FIELD_SNAPSHOTS = {MAX_FIELD_SNAPSHOTS}"):
        load_scene(scene)


def test_a_million_snapshots_are_refused_from_the_header_alone(tmp_path):
    """A node's load (the file changed since the scene was checked) refuses the series from
    the .npy header: the archive holds no data to read."""
    series_npz(tmp_path / "flow.npz", 2)
    field = load_scene(scene_file(tmp_path, "field.file", "flow.npz")).field
    header = b"{'descr': '<f4', 'fortran_order': False, 'shape': (1000000, 2, 2, 2, 3)}"
    npz(tmp_path / "flow.npz", velocity=npy_member(header),
        times=npy_member(b"{'descr': '<f8', 'fortran_order': False, 'shape': (1000000,)}"))
    with pytest.raises(FieldError, match="holds 1,000,000 snapshots; at most "
                                         f"MAX_FIELD_SNAPSHOTS = {MAX_FIELD_SNAPSHOTS}"):
        build_series(field)


def test_a_netcdf_series_past_the_snapshot_limit_is_refused_naming_it(tmp_path):
    path = tmp_path / "series.nc"
    times = np.arange(MAX_FIELD_SNAPSHOTS + 1, dtype=np.float64)
    velocity = np.zeros((len(times), 2, 2, 2), np.float32)
    coords = {axis: (axis, [0.0, 1.0], {"units": "m"}) for axis in "xyz"}
    coords["time"] = ("time", times, {"units": "seconds since 2026-01-01"})
    xr.Dataset({name: (("time", "z", "y", "x"), velocity, {"units": "m/s"}) for name in "uvw"},
               coords=coords).to_netcdf(path)
    data = scene_dict()
    data["field"] = {"kind": "file", "file": str(path)}
    with pytest.raises(SceneError, match=f"time dimension 'time' holds "
                                         f"{MAX_FIELD_SNAPSHOTS + 1:,} snapshots; at most "
                                         f"MAX_FIELD_SNAPSHOTS = {MAX_FIELD_SNAPSHOTS}"):
        parse_scene(data, name="series")


@pytest.mark.parametrize("resolution, snapshots, words", [
    ([2, 2, 2], MAX_FIELD_SNAPSHOTS + 1, f"<= {MAX_FIELD_SNAPSHOTS}"),
    ([128, 128, 256], 9, f"at most MAX_FIELD_SERIES_NODES = {MAX_FIELD_SERIES_NODES:,}"),
], ids=["snapshots", "nodes"])
def test_a_rotating_series_past_the_limits_is_refused_naming_them(resolution, snapshots,
                                                                   words):
    data = scene_dict()
    data["field"] = {"kind": "rotating", "box_min": [0, 0, 0], "box_max": [1, 1, 1],
                     "resolution": resolution, "params": {
                         "velocity": [1.0, 0.0, 0.0], "angular_speed": 1.0,
                         "snapshot_interval": 1.0, "snapshots": snapshots}}
    with pytest.raises(SceneError, match=r"field\.params\.snapshots = ") as raised:
        parse_scene(data, name="rotating")
    assert words in str(raised.value)


def test_cavesim_run_refuses_a_series_past_the_limit_in_one_line(tmp_path, capsys):
    series_npz(tmp_path / "flow.npz", MAX_FIELD_SNAPSHOTS + 1)
    scene = scene_file(tmp_path, "field.file", "flow.npz")
    assert cli.main(["run", "--scene", str(scene), "--out", str(tmp_path / "out")]) \
        == USAGE_ERROR
    line = one_line(capsys)
    assert line.startswith("cavesim run: error: argument --scene: ") and \
        f"MAX_FIELD_SNAPSHOTS = {MAX_FIELD_SNAPSHOTS}" in line, line
    assert not (tmp_path / "out").exists()


# -- finding: a glTF of 200k nodes stalls start-up ------------------------------------------

def test_a_gltf_of_more_nodes_than_the_limit_is_refused_before_it_is_walked(tmp_path):
    path = chain_gltf(tmp_path / "chain.gltf", MAX_MODEL_NODES + 1)
    with pytest.raises(ModelError, match=f"{path}: {MAX_MODEL_NODES + 1:,} nodes; at most "
                                         f"MAX_MODEL_NODES = {MAX_MODEL_NODES:,} are read"):
        read_model(path)


def test_a_chain_of_nodes_at_the_limit_is_walked_without_recursion(tmp_path):
    model = read_model(chain_gltf(tmp_path / "chain.gltf", MAX_MODEL_NODES))
    assert model.body.shape == (3, 9)


def test_a_gltf_buffer_is_held_to_the_limit_before_it_is_read(tmp_path, monkeypatch):
    (tmp_path / "mesh.bin").write_bytes(bytes(64))
    declared = gltf_json(tmp_path / "declared.gltf",
                         {"buffers": [{"byteLength": 2**40, "uri": "mesh.bin"}]})
    with pytest.raises(ModelError, match=f"{declared}: its buffer files declare "
                                         f"1,099,511,627,776 bytes; with the file's own, at "
                                         f"most MAX_MODEL_BYTES"):
        read_model(declared)
    held = gltf_json(tmp_path / "held.gltf", {"buffers": [{"byteLength": 36,
                                                           "uri": "mesh.bin"}]})
    assert read_model(held).body.shape == (3, 9)
    monkeypatch.setattr(gltf_file, "MAX_MODEL_BYTES", held.stat().st_size + 63)
    with pytest.raises(ModelError, match=f"buffer 0 of {held} is 64 bytes; at most 63 bytes"):
        read_model(held)


@pytest.mark.parametrize("kind", NOT_REGULAR)
def test_a_gltf_buffer_that_is_no_regular_file_is_one_line(tmp_path, kind):
    make, what = NOT_REGULAR[kind]
    target = make(tmp_path / "mesh.bin")
    path = gltf_json(tmp_path / "model.gltf", {"buffers": [{"byteLength": 36,
                                                            "uri": str(target)}]})
    with pytest.raises(ModelError, match=re.escape(f"{target}: buffer 0 of {path} {what}")):
        within_bound(lambda: read_model(path), target)
