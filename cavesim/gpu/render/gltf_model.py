"""A helicopter model from a glTF 2.0 file (.glb or .gltf): the scene's `[helicopter] model`.

It becomes the rows `meshes.py` makes (position, normal, colour per vertex; VERTEX_FORMAT)
in the model frame the pose places, and `WallRenderer` draws them in place of the built-in
body. What a file must be:

- Axes and units: glTF's own (Y up, +Z forward, +X left; metres) become the model frame's
  (x the nose's direction, y left, z up), a rotation: right-handed on both sides.
- The origin lies on the ground between the skids and the main rotor's hub at glTF
  (0, MESH_HUB_HEIGHT, 0); the pose scales the model by hub_height / MESH_HUB_HEIGHT, as it
  does the built-in body, and draws the main rotor's disc at the hub.
- Every node of the file's scene (its default one, else the first) is drawn through its
  transform in the node hierarchy (matrix, or translation, rotation and scale). Primitives
  are triangles, indexed or not (other modes are refused), MAX_TRIANGLES in all at most.
- Colour: each primitive material's baseColorFactor (RGB, as cavesim's own colours are;
  white without a material); textures, vertex colours and alpha are ignored.
- Normals: the file's NORMAL, else each triangle's own (flat shading).
- A node named TAIL_ROTOR_NODE is the tail rotor, not body (its mesh and children are not
  drawn): its origin is the hub, and the radius is its scale's largest component (with its
  parents'), in metres, as if it scaled a unit disc. The disc turns about the model's y.
  A file without one has no tail rotor drawn.
"""

from __future__ import annotations

import struct
import warnings
from pathlib import Path

import numpy as np
import pygltflib

from cavesim.core.errors import ModelError
from cavesim.core.scene.model import MODEL_SUFFIXES, Scene
from cavesim.gpu.render.meshes import HelicopterModel, TailRotor, built_in_helicopter

MAX_TRIANGLES = 500_000  # of a model in all: 54 MB of rows
TAIL_ROTOR_NODE = "tail_rotor"
# glTF's z (forward), x (left) and y (up) are the model's x, y and z: a cyclic permutation
MODEL_FROM_GLTF = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
_MODES = ("points", "lines", "line loop", "line strip", "triangles", "triangle strip",
          "triangle fan")  # a primitive's mode is its index here
_ACCESSORS = {  # what is read: accessor type, its width and its component types' dtypes
    "VEC3": (3, {pygltflib.FLOAT: "<f4"}),  # positions and normals
    "SCALAR": (1, {pygltflib.UNSIGNED_BYTE: "<u1", pygltflib.UNSIGNED_SHORT: "<u2",
                   pygltflib.UNSIGNED_INT: "<u4"}),  # indices
}
_ALLOWED = (f"a helicopter model must be a glTF 2.0 file ({' or '.join(MODEL_SUFFIXES)}) of "
            f"triangle meshes, at most {MAX_TRIANGLES} triangles")
_UNREADABLE = (OSError, ValueError, TypeError, AttributeError, KeyError, IndexError,
               struct.error)  # what pygltflib and numpy raise on a broken file


def helicopter_model(scene: Scene) -> HelicopterModel:
    """The helicopter the walls draw for `scene`: its model file's, else the built-in one."""
    model = scene.helicopter.model if scene.helicopter is not None else None
    return built_in_helicopter() if model is None else read_model(model)


def read_model(path: Path) -> HelicopterModel:
    """The glTF file at `path` as a helicopter model (ModelError if it cannot be one)."""
    try:
        with warnings.catch_warnings():  # pygltflib warns where it should fail
            warnings.simplefilter("ignore")
            gltf = pygltflib.GLTF2.load(path)
            if gltf is None:
                raise ValueError("a .glb file without its JSON chunk")
            buffers = [gltf.get_data_from_buffer_uri(b.uri) for b in gltf.buffers]
        if None in buffers:
            raise ValueError("a buffer's data is not found")
        return _Reader(gltf, buffers, path).model()
    except ModelError:
        raise
    except _UNREADABLE as e:
        raise ModelError(f"{path}: not a readable glTF 2.0 file ({type(e).__name__}: "
                         f"{e}); {_ALLOWED}") from e


class _Reader:
    """One file's node hierarchy walked into body rows and its tail rotor."""

    def __init__(self, gltf: pygltflib.GLTF2, buffers: list[bytes], path: Path) -> None:
        self.gltf, self.buffers, self.path = gltf, buffers, path
        self.triangles = 0

    def fail(self, what: str) -> ModelError:
        return ModelError(f"{self.path}: {what}; {_ALLOWED}")

    def model(self) -> HelicopterModel:
        gltf = self.gltf
        roots = gltf.scenes[gltf.scene or 0].nodes if gltf.scenes else []
        frame = np.eye(4)
        frame[:3, :3] = MODEL_FROM_GLTF
        parts, tail_rotors, seen = [], [], set()
        stack = [(index, frame) for index in roots]
        while stack:
            index, above = stack.pop()
            if index in seen:
                raise self.fail(f"node {index} is reached twice: the nodes must form trees")
            seen.add(index)
            node = gltf.nodes[index]
            matrix = above @ _local_matrix(node)
            if node.name == TAIL_ROTOR_NODE:
                tail_rotors.append(TailRotor(tuple(matrix[:3, 3].tolist()),
                                             float(np.linalg.norm(matrix[:3, :3], axis=0).max())))
                continue
            if node.mesh is not None:
                mesh = gltf.meshes[node.mesh]
                named = f"mesh {node.mesh}" + (f" {mesh.name!r}" if mesh.name else "")
                parts += [self.rows(primitive, matrix, f"{named} primitive {k}")
                          for k, primitive in enumerate(mesh.primitives)]
            stack += [(child, matrix) for child in node.children or ()]
        if self.triangles == 0:
            raise self.fail("it holds no triangles in its scene's nodes")
        if len(tail_rotors) > 1:
            raise self.fail(f"{len(tail_rotors)} nodes are named {TAIL_ROTOR_NODE!r}; one at most")
        return HelicopterModel(np.concatenate(parts),
                               tail_rotors[0] if tail_rotors else None)

    def rows(self, primitive: pygltflib.Primitive, matrix: np.ndarray,
             where: str) -> np.ndarray:
        """A primitive's triangles as (3 * triangles, 9) float32 rows in the model frame."""
        mode = pygltflib.TRIANGLES if primitive.mode is None else primitive.mode
        if mode != pygltflib.TRIANGLES:
            named = _MODES[mode] if mode in range(len(_MODES)) else "unknown"
            raise self.fail(f"{where} has mode {mode} ({named}); only mode "
                            f"{pygltflib.TRIANGLES} (triangles) is drawn")
        attributes = primitive.attributes
        positions = self.accessor(attributes.POSITION, "VEC3", f"{where}'s POSITION")
        corners = (np.arange(len(positions)) if primitive.indices is None else
                   self.accessor(primitive.indices, "SCALAR", f"{where}'s indices")[:, 0])
        self.triangles += len(corners) // 3
        if self.triangles > MAX_TRIANGLES:
            raise self.fail(f"more than {MAX_TRIANGLES} triangles (at {where})")
        corners = corners[:len(corners) // 3 * 3]
        if attributes.NORMAL is None:
            a, b, c = positions[corners].reshape(-1, 3, 3).transpose(1, 0, 2)
            normals = np.repeat(np.cross(b - a, c - a), 3, axis=0)
        else:
            normals = self.accessor(attributes.NORMAL, "VEC3", f"{where}'s NORMAL")[corners]
        normals = normals @ np.linalg.pinv(matrix[:3, :3])  # by the inverse transpose
        length = np.linalg.norm(normals, axis=1, keepdims=True)
        rows = np.empty((len(corners), 9), np.float32)
        rows[:, 0:3] = positions[corners] @ matrix[:3, :3].T + matrix[:3, 3]
        rows[:, 3:6] = normals / np.maximum(length, 1e-30)
        rows[:, 6:9] = self.color(primitive.material)
        return rows

    def color(self, material: int | None) -> list[float]:
        pbr = None if material is None else self.gltf.materials[material].pbrMetallicRoughness
        return [1.0, 1.0, 1.0] if pbr is None else pbr.baseColorFactor[:3]

    def accessor(self, index: int | None, kind: str, what: str) -> np.ndarray:
        """Accessor `index` as a (count, width) array of floats or unsigned ints."""
        if index is None:
            raise self.fail(f"{what} is missing")
        accessor = self.gltf.accessors[index]
        width, dtypes = _ACCESSORS[kind]
        if accessor.type != kind or accessor.componentType not in dtypes:
            raise self.fail(f"{what} is a {accessor.type} of component type "
                            f"{accessor.componentType}; it must be a {kind} of "
                            f"{' or '.join(map(str, dtypes))}")
        if accessor.bufferView is None or accessor.sparse is not None:
            raise self.fail(f"{what} has no bufferView, or is sparse; neither is read")
        view = self.gltf.bufferViews[accessor.bufferView]
        dtype = np.dtype(dtypes[accessor.componentType])
        return np.ndarray((accessor.count, width), dtype, self.buffers[view.buffer],
                          (view.byteOffset or 0) + (accessor.byteOffset or 0),
                          (view.byteStride or dtype.itemsize * width, dtype.itemsize))


def _local_matrix(node: pygltflib.Node) -> np.ndarray:
    """4x4 parent-from-node matrix: the node's matrix (column-major), else T * R * S."""
    if node.matrix:
        return np.array(node.matrix, float).reshape(4, 4).T
    x, y, z, w = node.rotation or (0.0, 0.0, 0.0, 1.0)
    m = np.eye(4)
    m[:3, :3] = [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                 [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                 [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]
    m[:3, :3] *= node.scale or (1.0, 1.0, 1.0)  # scales the columns: R * S
    m[:3, 3] = node.translation or (0.0, 0.0, 0.0)
    return m
