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
  are triangles, indexed or not (other modes are refused), MAX_MODEL_TRIANGLES in all at
  most, in MAX_MODEL_NODES primitives drawn at most; the file itself is read within its
  limits first (`gltf_file.py`).
- Colour: each primitive material's baseColorFactor (RGB, as cavesim's own colours are;
  white without a material); textures, vertex colours and alpha are ignored.
- Normals: the file's NORMAL, else each triangle's own (flat shading).
- A node named TAIL_ROTOR_NODE is the tail rotor, not body (its mesh and children are not
  drawn): its origin is the hub, and the radius is its scale's largest component (with its
  parents'), in metres, as if it scaled a unit disc. The disc turns about the model's y.
  A file without one has no tail rotor drawn.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from cavesim.core.errors import ModelError
from cavesim.core.limits import MAX_MODEL_NODES, MAX_MODEL_TRIANGLES
from cavesim.core.scene.model import MODEL_SUFFIXES, Scene
from cavesim.gpu.render.gltf_file import GltfFile, read_gltf
from cavesim.gpu.render.meshes import HelicopterModel, TailRotor, built_in_helicopter

TAIL_ROTOR_NODE = "tail_rotor"
# glTF's z (forward), x (left) and y (up) are the model's x, y and z: a cyclic permutation
MODEL_FROM_GLTF = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
TRIANGLES = 4  # a primitive's mode; the default
_MODES = ("points", "lines", "line loop", "line strip", "triangles", "triangle strip",
          "triangle fan")  # a primitive's mode is its index here
_FLOAT, _UNSIGNED_BYTE, _UNSIGNED_SHORT, _UNSIGNED_INT = 5126, 5121, 5123, 5125
_ACCESSORS = {  # what is read: accessor type, its width and its component types' dtypes
    "VEC3": (3, {_FLOAT: "<f4"}),  # positions and normals
    "SCALAR": (1, {_UNSIGNED_BYTE: "<u1", _UNSIGNED_SHORT: "<u2",
                   _UNSIGNED_INT: "<u4"}),  # indices
}
_ALLOWED = (f"a helicopter model must be a glTF 2.0 file ({' or '.join(MODEL_SUFFIXES)}) of "
            f"triangle meshes, at most {MAX_MODEL_TRIANGLES} triangles")
# what numpy and the walk raise on values of the wrong type or size in a file's JSON
_UNREADABLE = (ValueError, TypeError, AttributeError, KeyError, IndexError)


def helicopter_model(scene: Scene) -> HelicopterModel:
    """The helicopter the walls draw for `scene`: its model file's, else the built-in one."""
    model = scene.helicopter.model if scene.helicopter is not None else None
    return built_in_helicopter() if model is None else read_model(model)


def read_model(path: Path) -> HelicopterModel:
    """The glTF file at `path` as a helicopter model (ModelError if it cannot be one)."""
    try:
        gltf = read_gltf(path)
    except ModelError as e:
        raise ModelError(f"{e}; {_ALLOWED}") from e.__cause__ or e
    try:
        return _Reader(gltf, path).model()
    except ModelError:
        raise
    except _UNREADABLE as e:
        raise ModelError(f"{path}: not a readable glTF 2.0 file ({type(e).__name__}: "
                         f"{e}); {_ALLOWED}") from e


class _Reader:
    """One file's node hierarchy walked into body rows and its tail rotor."""

    def __init__(self, gltf: GltfFile, path: Path) -> None:
        self.document, self.buffers, self.path = gltf.document, gltf.buffers, path
        self.triangles = self.primitives = 0

    def fail(self, what: str) -> ModelError:
        return ModelError(f"{self.path}: {what}; {_ALLOWED}")

    def item(self, kind: str, index: object) -> dict:
        """Entry `index` of the document's array `kind`, which must exist."""
        items = self.document.get(kind, [])
        if type(index) is not int or not 0 <= index < len(items):
            raise self.fail(f"{kind} {index!r} is named but there is no such entry (the file "
                            f"has {len(items)})")
        return items[index]

    def model(self) -> HelicopterModel:
        scenes = self.document.get("scenes")
        roots = self.item("scenes", self.document.get("scene") or 0).get("nodes", []) \
            if scenes else []
        frame = np.eye(4)
        frame[:3, :3] = MODEL_FROM_GLTF
        parts, tail_rotors, seen = [], [], set()
        stack = [(index, frame) for index in roots]
        while stack:
            index, above = stack.pop()
            node = self.item("nodes", index)
            if index in seen:
                raise self.fail(f"node {index} is reached twice: the nodes must form trees")
            seen.add(index)
            matrix = above @ _local_matrix(node)
            if node.get("name") == TAIL_ROTOR_NODE:
                tail_rotors.append(TailRotor(tuple(matrix[:3, 3].tolist()),
                                             float(np.linalg.norm(matrix[:3, :3], axis=0).max())))
                continue
            if node.get("mesh") is not None:
                parts += self.mesh_rows(node["mesh"], matrix)
            stack += [(child, matrix) for child in node.get("children", ())]
        if self.triangles == 0:
            raise self.fail("it holds no triangles in its scene's nodes")
        if len(tail_rotors) > 1:
            raise self.fail(f"{len(tail_rotors)} nodes are named {TAIL_ROTOR_NODE!r}; one at most")
        return HelicopterModel(np.concatenate(parts),
                               tail_rotors[0] if tail_rotors else None)

    def mesh_rows(self, index: int, matrix: np.ndarray) -> list[np.ndarray]:
        """The rows of each primitive of mesh `index`, placed by `matrix`."""
        mesh = self.item("meshes", index)
        named = f"mesh {index}" + (f" {mesh['name']!r}" if mesh.get("name") else "")
        primitives = mesh.get("primitives", [])
        self.primitives += len(primitives)
        if self.primitives > MAX_MODEL_NODES:
            raise self.fail(f"more than MAX_MODEL_NODES = {MAX_MODEL_NODES:,} primitives drawn "
                            f"(at {named})")
        return [self.rows(primitive, matrix, f"{named} primitive {k}")
                for k, primitive in enumerate(primitives)]

    def rows(self, primitive: dict, matrix: np.ndarray, where: str) -> np.ndarray:
        """A primitive's triangles as (3 * triangles, 9) float32 rows in the model frame."""
        mode = primitive.get("mode", TRIANGLES)
        if mode != TRIANGLES:
            named = _MODES[mode] if mode in range(len(_MODES)) else "unknown"
            raise self.fail(f"{where} has mode {mode} ({named}); only mode "
                            f"{TRIANGLES} (triangles) is drawn")
        attributes = primitive.get("attributes", {})
        positions = self.accessor(attributes.get("POSITION"), "VEC3", f"{where}'s POSITION")
        indices = primitive.get("indices")
        corners = (np.arange(len(positions)) if indices is None else
                   self.accessor(indices, "SCALAR", f"{where}'s indices")[:, 0])
        self.triangles += len(corners) // 3
        if self.triangles > MAX_MODEL_TRIANGLES:
            raise self.fail(f"more than {MAX_MODEL_TRIANGLES} triangles (at {where})")
        corners = corners[:len(corners) // 3 * 3]
        if attributes.get("NORMAL") is None:
            a, b, c = positions[corners].reshape(-1, 3, 3).transpose(1, 0, 2)
            normals = np.repeat(np.cross(b - a, c - a), 3, axis=0)
        else:
            normals = self.accessor(attributes["NORMAL"], "VEC3", f"{where}'s NORMAL")[corners]
        normals = normals @ np.linalg.pinv(matrix[:3, :3])  # by the inverse transpose
        length = np.linalg.norm(normals, axis=1, keepdims=True)
        rows = np.empty((len(corners), 9), np.float32)
        rows[:, 0:3] = positions[corners] @ matrix[:3, :3].T + matrix[:3, 3]
        rows[:, 3:6] = normals / np.maximum(length, 1e-30)
        rows[:, 6:9] = self.color(primitive.get("material"))
        return rows

    def color(self, material: int | None) -> list[float]:
        pbr = None if material is None else \
            self.item("materials", material).get("pbrMetallicRoughness")
        return [1.0, 1.0, 1.0] if pbr is None else pbr.get("baseColorFactor", [1.0] * 4)[:3]

    def accessor(self, index: int | None, kind: str, what: str) -> np.ndarray:
        """Accessor `index` as a (count, width) array of floats or unsigned ints."""
        if index is None:
            raise self.fail(f"{what} is missing")
        accessor = self.item("accessors", index)
        width, dtypes = _ACCESSORS[kind]
        if accessor.get("type") != kind or accessor.get("componentType") not in dtypes:
            raise self.fail(f"{what} is a {accessor.get('type')} of component type "
                            f"{accessor.get('componentType')}; it must be a {kind} of "
                            f"{' or '.join(map(str, dtypes))}")
        if accessor.get("bufferView") is None or accessor.get("sparse") is not None:
            raise self.fail(f"{what} has no bufferView, or is sparse; neither is read")
        view = self.item("bufferViews", accessor["bufferView"])
        self.item("buffers", view.get("buffer"))
        dtype = np.dtype(dtypes[accessor["componentType"]])
        return np.ndarray((accessor["count"], width), dtype, self.buffers[view["buffer"]],
                          view.get("byteOffset", 0) + accessor.get("byteOffset", 0),
                          (view.get("byteStride") or dtype.itemsize * width, dtype.itemsize))


def _local_matrix(node: dict) -> np.ndarray:
    """4x4 parent-from-node matrix: the node's matrix (column-major), else T * R * S."""
    if node.get("matrix"):
        return np.array(node["matrix"], float).reshape(4, 4).T
    x, y, z, w = node.get("rotation") or (0.0, 0.0, 0.0, 1.0)
    m = np.eye(4)
    m[:3, :3] = [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                 [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                 [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]
    m[:3, :3] *= node.get("scale") or (1.0, 1.0, 1.0)  # scales the columns: R * S
    m[:3, 3] = node.get("translation") or (0.0, 0.0, 0.0)
    return m
