"""Decoding VTK XML ImageData (.vti) files: the grid's geometry and one point vector array.

Only the format lives here; `cavesim.core.fields.flow_files` checks sizes, units and values.
Every malformed input becomes one FieldError naming the file and the element or attribute.
"""

from __future__ import annotations

import base64
import binascii
import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from cavesim.core.errors import FieldError
from cavesim.core.input_files import open_input
from cavesim.core.limits import MAX_FIELD_FILE_BYTES

VTK_TYPES = {"Float32": "f4", "Float64": "f8"}
VTK_HEADER_TYPES = {"UInt32": "u4", "UInt64": "u8"}
VTK_BYTE_ORDERS = {"LittleEndian": "<", "BigEndian": ">"}
VTK_STORAGE = ("ascii or binary (base64) DataArrays, uncompressed; save with compression off, "
               "e.g. in ParaView: Data Mode ascii or binary and Compressor None")
IDENTITY = (1, 0, 0, 0, 1, 0, 0, 0, 1)


@dataclass(frozen=True, eq=False)
class ImageData:
    """The parsed file: its root element and the ImageData's extent, origin and spacing."""

    root: ET.Element
    extent: tuple[int, ...]  # WholeExtent: x0 x1 y0 y1 z0 z1, node indices
    origin: tuple[float, ...]
    spacing: tuple[float, ...]

    @property
    def shape(self) -> tuple[int, int, int]:
        """Nodes per axis as (nz, ny, nx)."""
        x0, x1, y0, y1, z0, z1 = self.extent
        return z1 - z0 + 1, y1 - y0 + 1, x1 - x0 + 1

    @property
    def corners(self) -> tuple[tuple[float, ...], tuple[float, ...]]:
        """Positions (x, y, z) of the first and of the last node on each axis."""
        return tuple(tuple(o + s * e for o, s, e in zip(self.origin, self.spacing,
                                                        self.extent[end::2], strict=True))
                     for end in (0, 1))


def read_image_data(path: Path) -> ImageData:
    """The file's ImageData geometry: axis-aligned (Direction the identity), Spacing > 0."""
    with open_input(path, FieldError, "the VTK file", MAX_FIELD_FILE_BYTES) as file:
        try:
            root = ET.parse(file).getroot()
        except (OSError, ET.ParseError) as e:
            raise FieldError(f"{path}: cannot read as VTK XML: {e}") from e
    image = root.find("ImageData")
    if root.tag != "VTKFile" or root.get("type") != "ImageData" or image is None:
        raise FieldError(f"{path}: root <{root.tag} type={root.get('type')!r}>; expected "
                         "<VTKFile type=\"ImageData\"> holding an <ImageData>")
    if root.get("compressor") or root.find("AppendedData") is not None:
        raise FieldError(f"{path}: holds compressed or appended data; expected {VTK_STORAGE}")
    spacing = _numbers(path, image, "Spacing", 3, float)
    if min(spacing) <= 0:
        raise FieldError(f"{path}: ImageData Spacing is {spacing}; expected 3 positive numbers")
    if "Direction" in image.attrib and _numbers(path, image, "Direction", 9, float) != IDENTITY:
        raise FieldError(f"{path}: ImageData Direction is {image.get('Direction')!r}; expected "
                         "the identity (grid axes along x, y, z)")
    return ImageData(root, _numbers(path, image, "WholeExtent", 6, int),
                     _numbers(path, image, "Origin", 3, float), spacing)


def point_vectors(path: Path, image: ImageData, name: str | None) -> tuple[str, np.ndarray]:
    """The name and float64 values (nz, ny, nx, 3) of the 3-component point array: `name`,
    else the one PointData's Vectors attribute names, else the only 3-component one."""
    pieces = image.root.findall("ImageData/Piece")
    whole = image.root.find("ImageData").get("WholeExtent")
    if len(pieces) != 1 or pieces[0].get("Extent", whole).split() != whole.split():
        raise FieldError(f"{path}: holds {len(pieces)} pieces; expected one, whose Extent is "
                         "the WholeExtent")
    point_data = pieces[0].find("PointData")
    arrays = [] if point_data is None else point_data.findall("DataArray")
    if not arrays:
        raise FieldError(f"{path}: has no PointData arrays (CellData arrays: "
                         f"{len(pieces[0].findall('CellData/DataArray'))}); expected a "
                         "3-component point array, the velocity at the nodes")
    wanted = name or point_data.get("Vectors")
    if wanted:
        found, what = [a for a in arrays if a.get("Name") == wanted], f"arrays named {wanted!r}"
    else:
        found = [a for a in arrays if a.get("NumberOfComponents") == "3"]
        what = "3-component arrays"
    if len(found) != 1:
        raise FieldError(f"{path}: PointData holds {len(found)} {what} among "
                         f"{[a.get('Name') for a in arrays]}; expected one, or the scene naming it")
    array, where = found[0], f"PointData array {found[0].get('Name')!r}"
    if array.get("NumberOfComponents", "1") != "3":
        raise FieldError(f"{path}: {where} has NumberOfComponents="
                         f"{array.get('NumberOfComponents', '1')}; expected 3 (x, y, z)")
    count = math.prod(image.shape) * 3
    return where, _array_values(path, image.root, array, where, count).reshape(*image.shape, 3)


def _numbers(path, element, attribute, count, kind) -> tuple:
    text = element.get(attribute, "")
    try:
        numbers = tuple(kind(word) for word in text.split())
    except ValueError:
        numbers = ()
    if len(numbers) != count or not all(map(math.isfinite, numbers)):
        raise FieldError(f"{path}: ImageData {attribute}={text!r}; expected {count} finite "
                         f"{'integers' if kind is int else 'numbers'}")
    return numbers


def _array_values(path, root, array, where, count) -> np.ndarray:
    """The DataArray's `count` numbers as float64, from ascii or uncompressed base64 text."""
    kind, storage, text = array.get("type"), array.get("format"), array.text or ""
    if kind not in VTK_TYPES:
        raise FieldError(f"{path}: {where} has type {kind!r}; expected {list(VTK_TYPES)}")
    if storage not in ("ascii", "binary") or array.get("compressor"):
        raise FieldError(f"{path}: {where} has format {storage!r}; expected {VTK_STORAGE}")
    try:
        if storage == "ascii":
            values = np.array(text.split(), dtype=np.float64)
        else:
            values = _base64_values(root, text, kind)
    except (ValueError, binascii.Error) as e:
        raise FieldError(f"{path}: {where} cannot be decoded as {storage} {kind}: {e}") from e
    if values.size != count:
        raise FieldError(f"{path}: {where} holds {values.size} numbers; expected {count} "
                         "(3 per node of the WholeExtent)")
    return values


def _base64_values(root, text, kind) -> np.ndarray:
    """Base64 of a header (the data's byte count, UInt32 or UInt64 as the VTKFile's
    header_type says) then the data, both in the VTKFile's byte_order."""
    order = VTK_BYTE_ORDERS.get(root.get("byte_order", "LittleEndian"))
    header_type = VTK_HEADER_TYPES.get(root.get("header_type", "UInt32"))
    if order is None or header_type is None:
        raise ValueError(f"VTKFile byte_order {root.get('byte_order')!r} or header_type "
                         f"{root.get('header_type')!r} unknown; expected one of "
                         f"{list(VTK_BYTE_ORDERS)} and of {list(VTK_HEADER_TYPES)}")
    raw = base64.b64decode("".join(text.split()), validate=True)
    header = np.dtype(order + header_type)
    if len(raw) < header.itemsize:
        raise ValueError(f"{len(raw)} bytes, fewer than its {header.itemsize}-byte header")
    size = int(np.frombuffer(raw, header, count=1)[0])
    if size != len(raw) - header.itemsize:
        raise ValueError(f"its header gives {size} bytes, but {len(raw) - header.itemsize} follow")
    return np.frombuffer(raw[header.itemsize:], order + VTK_TYPES[kind]).astype(np.float64)
