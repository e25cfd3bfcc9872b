"""Small glTF files built in a test with pygltflib: a few triangles each, in glTF's axes."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pygltflib

from cavesim.gpu.render.meshes import box

RED = (0.9, 0.1, 0.1)


def write_gltf(path: Path, meshes: list[dict], nodes: list[pygltflib.Node],
               roots: list[int] | None = None) -> Path:
    """A glTF file (.glb, or .gltf with a .bin beside it) of `meshes`, each one primitive
    given as a dict of "positions" (N, 3) in glTF's axes and optionally "normals",
    "indices" (uint16), "color" and "mode"; `roots` are the scene's nodes (default all)."""
    roots = list(range(len(nodes))) if roots is None else roots
    gltf = pygltflib.GLTF2(scene=0, scenes=[pygltflib.Scene(nodes=roots)], nodes=nodes,
                           buffers=[pygltflib.Buffer()])
    blob = bytearray()

    def accessor(data: np.ndarray, kind: str, component: int) -> int:
        gltf.bufferViews.append(pygltflib.BufferView(buffer=0, byteOffset=len(blob),
                                                     byteLength=data.nbytes))
        gltf.accessors.append(pygltflib.Accessor(bufferView=len(gltf.bufferViews) - 1,
                                                 componentType=component, count=len(data),
                                                 type=kind))
        blob.extend(data.tobytes() + bytes(-data.nbytes % 4))
        return len(gltf.accessors) - 1

    for mesh in meshes:
        attributes = pygltflib.Attributes(
            POSITION=accessor(np.asarray(mesh["positions"], "<f4"), "VEC3", pygltflib.FLOAT))
        if "normals" in mesh:
            attributes.NORMAL = accessor(np.asarray(mesh["normals"], "<f4"), "VEC3",
                                         pygltflib.FLOAT)
        indices = None
        if "indices" in mesh:
            indices = accessor(np.asarray(mesh["indices"], "<u2"), "SCALAR",
                               pygltflib.UNSIGNED_SHORT)
        gltf.materials.append(pygltflib.Material(pbrMetallicRoughness=(
            pygltflib.PbrMetallicRoughness(baseColorFactor=[*mesh.get("color", RED), 1.0]))))
        gltf.meshes.append(pygltflib.Mesh(primitives=[pygltflib.Primitive(
            attributes=attributes, indices=indices, material=len(gltf.materials) - 1,
            mode=mesh.get("mode", pygltflib.TRIANGLES))]))
    gltf.buffers[0].byteLength = len(blob)
    gltf.set_binary_blob(bytes(blob))
    if path.suffix == ".glb":
        gltf.save_binary(str(path))
    else:
        gltf.save_json(str(path))
    return path


def cube(center, size=(1.0, 1.0, 1.0)) -> dict:
    """A box mesh (36 corners, no indices, no normals) in glTF's axes."""
    return {"positions": box(center, size, RED)[:, 0:3]}
