"""Field-by-field differences between two copies of the same records (desync forensics).

A record's fields come from its dtype (`records.py`), vectors split into components
(`pos.y`). Each difference gives both values and both bit patterns, their XOR (a single
flipped bit shows as one set bit) and a distance: for floats the ULP distance, the
difference of the bit patterns read as ordered integers (adjacent floats are 1 apart, +0
and -0 are 0 apart); for integers the difference of the values.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

_KINDS = {("f", 4): "float32", ("f", 8): "float64", ("u", 4): "uint32", ("i", 4): "int32",
          ("u", 1): "uint8", ("i", 1): "int8"}
_COMPONENTS = "xyzw"
DISTANCE_UNITS = {"float32": "ULP (ordered-int distance of the float32 bits)",
                  "float64": "ULP (ordered-int distance of the float64 bits)",
                  **{kind: "integer difference" for kind in ("uint32", "int32", "uint8", "int8")}}


@dataclass(frozen=True)
class Field:
    """One scalar of a record: `pos.y`, `age`, ..."""

    name: str
    kind: str  # float32, float64, uint32, int32, uint8, int8
    offset: int  # bytes into the record
    size: int  # bytes


def record_fields(dtype: np.dtype) -> tuple[Field, ...]:
    """The record's scalars in byte order, vectors split into components."""
    fields = []
    for name, (sub, offset) in sorted(dtype.fields.items(), key=lambda f: f[1][1]):
        base, count = sub.base, int(np.prod(sub.shape)) if sub.shape else 1
        kind = _KINDS[(base.kind, base.itemsize)]
        for i in range(count):
            label = f"{name}.{_COMPONENTS[i]}" if sub.shape else name
            fields.append(Field(label, kind, offset + i * base.itemsize, base.itemsize))
    return tuple(fields)


def field_bit(dtype: np.dtype, word: int, bit: int) -> tuple[Field, int]:
    """The field holding bit `bit` of 32-bit word `word` of a record, and the bit's place
    in that field (a float64's high word holds its bits 32 to 63)."""
    byte = word * 4
    field = next((f for f in record_fields(dtype) if f.offset <= byte < f.offset + f.size),
                 None)
    if field is None or not 0 <= bit < 32:
        raise ValueError(f"word {word} bit {bit} is not within a {dtype.itemsize}-byte record")
    return field, (byte - field.offset) * 8 + bit


@dataclass(frozen=True)
class FieldDifference:
    record: int
    field: Field
    bits: tuple[int, int]  # the field's bit patterns: (odd node's, reference node's)

    @property
    def values(self) -> tuple[float | int, float | int]:
        return tuple(_value(self.field.kind, b) for b in self.bits)

    @property
    def distance(self) -> int:
        a, b = self.bits
        if self.field.kind.startswith("float"):
            return abs(_ordered(a, self.field.size) - _ordered(b, self.field.size))
        return abs(_value(self.field.kind, a) - _value(self.field.kind, b))

    def hex(self, bits: int) -> str:
        return f"0x{bits:0{self.field.size * 2}x}"

    def shown(self, value: float | int) -> str:
        """A value as a person reads it: a float32 in its shortest round-trip form."""
        if self.field.kind == "float32":
            return str(np.float32(value))
        return repr(value)

    def to_json(self) -> dict:
        names = ("odd", "reference")
        return {
            "field": self.field.name, "type": self.field.kind,
            **{name: {"value": self._json_value(value), "bits": self.hex(bits)}
               for name, value, bits in zip(names, self.values, self.bits, strict=True)},
            "xor": self.hex(self.bits[0] ^ self.bits[1]),
            "distance": self.distance, "distance_unit": DISTANCE_UNITS[self.field.kind],
        }


    def _json_value(self, value: float | int) -> float | int | str:
        """The value for JSON: a float32 in its shortest form, which parses back to the
        same float32; JSON has no NaN or infinities, so those become their names."""
        if self.field.kind == "float32":
            value = float(self.shown(value))
        if isinstance(value, float) and not math.isfinite(value):
            return repr(value)
        return value


def differences(dtype: np.dtype, indices: np.ndarray, odd: bytes, reference: bytes
                ) -> list[FieldDifference]:
    """Every field that differs between `odd` and `reference`, the same records (whose
    stream indices are `indices`) of two nodes, record by record."""
    size = dtype.itemsize
    if len(odd) != len(reference) or len(odd) != len(indices) * size:
        raise ValueError(f"{len(indices)} records of {size} bytes, got {len(odd)} and "
                         f"{len(reference)} bytes")
    a = np.frombuffer(odd, np.uint8).reshape(-1, size)
    b = np.frombuffer(reference, np.uint8).reshape(-1, size)
    found = []
    for row in np.flatnonzero((a != b).any(axis=1)):
        for field in record_fields(dtype):
            span = slice(field.offset, field.offset + field.size)
            if (a[row, span] != b[row, span]).any():
                bits = tuple(int.from_bytes(bytes(x[row, span]), "little") for x in (a, b))
                found.append(FieldDifference(int(indices[row]), field, bits))
    return found


def _value(kind: str, bits: int) -> float | int:
    if kind == "float32":
        return float(np.uint32(bits).view(np.float32))
    if kind == "float64":
        return float(np.uint64(bits).view(np.float64))
    return _signed(bits, int(kind[3:])) if kind.startswith("int") else bits


def _ordered(bits: int, size: int) -> int:
    """A float's bits as an integer that orders like the float (sign-magnitude to two's
    complement), so that neighbouring floats differ by 1."""
    sign = 1 << (size * 8 - 1)
    return -(bits & (sign - 1)) if bits & sign else bits


def _signed(bits: int, width: int) -> int:
    return bits - (1 << width) if bits >> (width - 1) else bits
