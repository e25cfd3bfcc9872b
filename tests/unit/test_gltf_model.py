"""A scene's own helicopter model: glTF files read into the model frame the pose places, the
shipped model that is the built-in helicopter, the scene key, and one clear line for each
file that cannot be a model. Files are built here with pygltflib, a few triangles each."""

from __future__ import annotations

import math
import tomllib
from pathlib import Path

import numpy as np
import pygltflib
import pytest
from gltf_files import RED, cube, write_gltf

from cavesim.core.errors import ModelError, SceneError
from cavesim.core.limits import MAX_MODEL_TRIANGLES
from cavesim.core.scene import parse_scene
from cavesim.gpu.render import gltf_model
from cavesim.gpu.render.gltf_model import read_model
from cavesim.gpu.render.meshes import built_in_helicopter
from cavesim.tools.export_helicopter import DEFAULT_PATH, main

ROOT = Path(__file__).parents[2]


def triangles(rows: np.ndarray) -> np.ndarray:
    """The triangles of `rows` (27 numbers each) in a fixed order."""
    flat = rows.reshape(-1, 27)
    return flat[np.lexsort(flat.T[::-1])]


@pytest.mark.parametrize("written", [False, True], ids=["shipped", "exported-now"])
def test_the_shipped_model_is_the_built_in_helicopter(tmp_path, written):
    path = ROOT / DEFAULT_PATH
    if written:
        path = tmp_path / "helicopter.glb"
        main([str(path)])
    model, built_in = read_model(path), built_in_helicopter()
    np.testing.assert_allclose(triangles(model.body), triangles(built_in.body), rtol=0,
                               atol=1e-6)
    np.testing.assert_allclose(model.tail_rotor.hub, built_in.tail_rotor.hub, atol=1e-6)
    assert model.tail_rotor.radius == pytest.approx(built_in.tail_rotor.radius, abs=1e-7)


@pytest.mark.parametrize("suffix", [".glb", ".gltf"])
def test_gltf_forward_left_and_up_become_the_model_x_y_and_z(tmp_path, suffix):
    """glTF: +Z forward, +X left, +Y up; the model: x forward, y left, z up."""
    offsets = {(0.0, 0.0, 3.0): (3.0, 0.0, 0.0), (2.0, 0.0, 0.0): (0.0, 2.0, 0.0),
               (0.0, 5.0, 0.0): (0.0, 0.0, 5.0)}
    for gltf_offset, model_offset in offsets.items():
        path = write_gltf(tmp_path / f"box{suffix}", [cube(gltf_offset)],
                          [pygltflib.Node(mesh=0)])
        body = read_model(path).body
        np.testing.assert_allclose(body[:, 0:3].mean(axis=0), model_offset, atol=1e-6)
        assert body.dtype == np.float32 and body.shape == (36, 9)
        np.testing.assert_allclose(body[:, 6:9], np.tile(RED, (36, 1)), atol=1e-7)
        outward = np.einsum("ij,ij->i", body[:, 3:6], body[:, 0:3] - model_offset)
        assert (outward > 0).all(), "flat normals point out of the box"


def test_node_transforms_are_honoured_through_the_hierarchy(tmp_path):
    """A triangle in a child (a matrix: scale 2, then 1 along x) of a parent turned 90
    degrees about glTF's Y and moved 10 forward."""
    triangle = {"positions": [(0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0)]}
    child = np.diag([2.0, 2.0, 2.0, 1.0])
    child[0, 3] = 1.0
    half = math.sqrt(0.5)
    nodes = [pygltflib.Node(children=[1], translation=[0.0, 0.0, 10.0],
                            rotation=[0.0, half, 0.0, half]),
             pygltflib.Node(mesh=0, matrix=child.T.ravel().tolist())]  # column-major
    body = read_model(write_gltf(tmp_path / "nested.glb", [triangle], nodes, roots=[0])).body
    # local (0,0,0), (1,0,0), (0,1,0) -> child (1,0,0), (3,0,0), (1,2,0) -> turned
    # (0,0,-1), (0,0,-3), (0,2,-1) -> moved (0,0,9), (0,0,7), (0,2,9): glTF z, x, y as x, y, z
    np.testing.assert_allclose(body[:, 0:3], [(9, 0, 0), (7, 0, 0), (9, 0, 2)], atol=1e-6)
    np.testing.assert_allclose(body[:, 3:6], np.tile((0.0, 1.0, 0.0), (3, 1)), atol=1e-6)


def test_indexed_triangles_take_the_files_normals(tmp_path):
    quad = {"positions": [(0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (1.0, 0.0, 1.0), (0.0, 0.0, 1.0)],
            "normals": [(0.0, 1.0, 0.0)] * 4, "indices": [0, 2, 1, 0, 3, 2],
            "color": (0.2, 0.4, 0.6)}
    body = read_model(write_gltf(tmp_path / "quad.gltf", [quad], [pygltflib.Node(mesh=0)])).body
    # the corners (0,0,0), (0,1,0), (1,1,0), (1,0,0) in the model frame, by the indices
    np.testing.assert_allclose(body[:, 0:3], [(0, 0, 0), (1, 1, 0), (0, 1, 0), (0, 0, 0),
                                              (1, 0, 0), (1, 1, 0)], atol=1e-7)
    np.testing.assert_allclose(body[:, 3:6], np.tile((0.0, 0.0, 1.0), (6, 1)), atol=1e-7)
    np.testing.assert_allclose(body[:, 6:9], np.tile((0.2, 0.4, 0.6), (6, 1)), atol=1e-7)


def test_a_tail_rotor_node_places_the_tail_rotor_and_is_not_drawn(tmp_path):
    nodes = [pygltflib.Node(mesh=0),
             pygltflib.Node(name="tail_rotor", mesh=1, translation=[0.3, 1.2, -4.0],
                            scale=[0.1, 0.45, 0.45])]
    path = write_gltf(tmp_path / "tail.glb", [cube((0.0, 0.5, 0.0)), cube((0.3, 1.2, -4.0))],
                      nodes)
    model = read_model(path)
    assert len(model.body) == 36, "the tail rotor's own mesh is not body"
    np.testing.assert_allclose(model.tail_rotor.hub, (-4.0, 0.3, 1.2), atol=1e-7)
    assert model.tail_rotor.radius == pytest.approx(0.45)
    without = write_gltf(tmp_path / "plain.glb", [cube((0.0, 0.5, 0.0))],
                         [pygltflib.Node(mesh=0)])
    assert read_model(without).tail_rotor is None


def broken_files(tmp_path: Path) -> dict[str, tuple[Path, str]]:
    """Files that cannot be a model, with the words their error must hold."""
    garbage = tmp_path / "garbage.glb"
    garbage.write_bytes(b"PK\x03\x04 not a glTF at all")
    prose = tmp_path / "prose.gltf"
    prose.write_text("a helicopter, roughly\n")
    empty = write_gltf(tmp_path / "empty.glb", [], [pygltflib.Node(name="nothing")])
    lines = write_gltf(tmp_path / "lines.glb", [{**cube((0, 0, 0)), "mode": pygltflib.LINES}],
                       [pygltflib.Node(mesh=0)])
    over = MAX_MODEL_TRIANGLES + 1  # of one triangle, again and again
    big = write_gltf(tmp_path / "big.glb", [{"positions": np.eye(3), "indices": np.tile(
        np.arange(3, dtype=np.uint16), over)}], [pygltflib.Node(mesh=0)])
    looped = write_gltf(tmp_path / "looped.glb", [cube((0, 0, 0))],
                        [pygltflib.Node(mesh=0, children=[0])])
    tails = write_gltf(tmp_path / "tails.glb", [cube((0, 0, 0))],
                       [pygltflib.Node(mesh=0), *[pygltflib.Node(name="tail_rotor")] * 2])
    return {
        "missing": (tmp_path / "gone.glb", "cannot read the model file: No such file"),
        "not glTF": (garbage, "not a .glb file: it begins b'PK\\x03\\x04'"),
        "not JSON": (prose, "its glTF JSON is not valid JSON: Expecting value"),
        "no triangles": (empty, "it holds no triangles"),
        "lines": (lines, "mesh 0 primitive 0 has mode 1 (lines); only mode 4 (triangles) is "
                         "drawn"),
        "too large": (big, f"more than {MAX_MODEL_TRIANGLES} triangles (at mesh 0 "
                           "primitive 0)"),
        "a loop": (looped, "node 0 is reached twice: the nodes must form trees"),
        "two tail rotors": (tails, "2 nodes are named 'tail_rotor'; one at most"),
    }


@pytest.mark.parametrize("case", ["missing", "not glTF", "not JSON", "no triangles", "lines",
                                  "too large", "a loop", "two tail rotors"])
def test_a_file_that_cannot_be_a_model_gets_one_line(tmp_path, case):
    path, words = broken_files(tmp_path)[case]
    with pytest.raises(ModelError) as raised:
        read_model(path)
    message = str(raised.value)
    assert "\n" not in message
    assert message.startswith(f"{path}: {words}"), message
    assert message.endswith("; a helicopter model must be a glTF 2.0 file (.glb or .gltf) of "
                            f"triangle meshes, at most {MAX_MODEL_TRIANGLES} "
                            "triangles"), message


def helicopter_scene(model: str) -> str:
    return f"""
[simulation]
capacity = 10
seed = 1

[helicopter]
mass = 1000.0
rotor_radius = 5.0
hub_height = 1.3
model = "{model}"
"""


def test_the_scene_names_its_model_relative_to_the_scene_file(tmp_path):
    (tmp_path / "models").mkdir()
    path = write_gltf(tmp_path / "models" / "box.glb", [cube((0, 0, 0))],
                      [pygltflib.Node(mesh=0)])
    source = tmp_path / "my.toml"
    scene = parse_scene(tomllib.loads(helicopter_scene("models/box.glb")), source)
    assert scene.helicopter.model.resolve() == path.resolve()
    assert gltf_model.helicopter_model(scene).body.shape == (36, 9)
    no_model = parse_scene({"simulation": {"capacity": 10, "seed": 1}})
    assert gltf_model.helicopter_model(no_model).tail_rotor is not None, "the built-in body"


@pytest.mark.parametrize("name,allowed", [
    ("gone.glb", "must be a non-empty string naming an existing file, a glTF file: .glb or "
                 ".gltf (looked for "),
    ("box.obj", "must be a non-empty string naming an existing file, a glTF file: .glb or "
                ".gltf"),
])
def test_a_scene_naming_no_gltf_file_is_refused_when_it_loads(tmp_path, name, allowed):
    (tmp_path / "box.obj").write_text("v 0 0 0\n")
    source = tmp_path / "my.toml"
    with pytest.raises(SceneError) as raised:
        parse_scene(tomllib.loads(helicopter_scene(name)), source)
    assert str(raised.value).startswith(
        f"{source}: helicopter.model = {name!r} is not allowed: {allowed}"), raised.value
