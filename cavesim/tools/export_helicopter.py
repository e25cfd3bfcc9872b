"""config/models/utility_helicopter.glb: the built-in helicopter written out as binary glTF,
a file for a scene's `[helicopter] model` to start from, and one the reader is tested on
(reading it gives the built-in body and tail rotor back). Written by
`python -m cavesim.tools.export_helicopter [PATH.glb]`.

The body is one mesh without indices, a primitive per colour (its material's
baseColorFactor); the tail rotor is a node named TAIL_ROTOR_NODE; the axes and the rest of
the conventions are `cavesim.gpu.render.gltf_model`'s.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import pygltflib

from cavesim.gpu.render.gltf_model import MODEL_FROM_GLTF, TAIL_ROTOR_NODE
from cavesim.gpu.render.meshes import HelicopterModel, built_in_helicopter

DEFAULT_PATH = Path("config/models/utility_helicopter.glb")


def export_helicopter(model: HelicopterModel, path: Path) -> None:
    """Write `model` to `path` as binary glTF (.glb)."""
    gltf = pygltflib.GLTF2(scene=0, buffers=[pygltflib.Buffer()])
    blob = bytearray()

    def accessor(values: np.ndarray) -> int:
        """A new VEC3 float accessor of `values` (model frame) in glTF's axes."""
        data = np.ascontiguousarray(values @ MODEL_FROM_GLTF, dtype="<f4")
        gltf.bufferViews.append(pygltflib.BufferView(buffer=0, byteOffset=len(blob),
                                                     byteLength=data.nbytes,
                                                     target=pygltflib.ARRAY_BUFFER))
        gltf.accessors.append(pygltflib.Accessor(
            bufferView=len(gltf.bufferViews) - 1, componentType=pygltflib.FLOAT,
            count=len(data), type=pygltflib.VEC3, min=data.min(axis=0).tolist(),
            max=data.max(axis=0).tolist()))
        blob.extend(data.tobytes())
        return len(gltf.accessors) - 1

    colors, which = np.unique(model.body[:, 6:9], axis=0, return_inverse=True)
    primitives = []
    for k, color in enumerate(colors):
        rows = model.body[which.ravel() == k]
        paint = pygltflib.PbrMetallicRoughness(baseColorFactor=[*color.tolist(), 1.0],
                                               metallicFactor=0.0)
        gltf.materials.append(pygltflib.Material(pbrMetallicRoughness=paint))
        primitives.append(pygltflib.Primitive(
            attributes=pygltflib.Attributes(POSITION=accessor(rows[:, 0:3]),
                                            NORMAL=accessor(rows[:, 3:6])), material=k))
    gltf.meshes.append(pygltflib.Mesh(name="body", primitives=primitives))
    gltf.nodes.append(pygltflib.Node(name="body", mesh=0))
    if model.tail_rotor is not None:
        hub, radius = model.tail_rotor.hub, model.tail_rotor.radius
        gltf.nodes.append(pygltflib.Node(name=TAIL_ROTOR_NODE,
                                         translation=(np.asarray(hub) @ MODEL_FROM_GLTF).tolist(),
                                         scale=[radius] * 3))
    gltf.scenes.append(pygltflib.Scene(nodes=list(range(len(gltf.nodes)))))
    gltf.buffers[0].byteLength = len(blob)
    gltf.set_binary_blob(bytes(blob))
    gltf.save_binary(str(path))


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="python -m cavesim.tools.export_helicopter",
                                     description="Write the built-in helicopter as .glb.")
    parser.add_argument("path", type=Path, nargs="?", default=DEFAULT_PATH,
                        help=f"the .glb file to write (default {DEFAULT_PATH})")
    path = parser.parse_args(argv).path
    if path.suffix.lower() != ".glb":
        parser.error(f"path: {str(path)!r} must end in .glb (binary glTF)")
    export_helicopter(built_in_helicopter(), path)


if __name__ == "__main__":
    main()
