"""The columns and key-value metadata of trajectories.parquet: one table that the writer,
the loaders and the docs test all read."""

from __future__ import annotations

from dataclasses import dataclass

import pyarrow as pa


@dataclass(frozen=True)
class Column:
    name: str
    type: pa.DataType
    unit: str  # "" where the value has none
    meaning: str

    @property
    def type_name(self) -> str:
        """The type as docs/trajectories.md names it (numpy's names for floats)."""
        return {"double": "float64", "float": "float32"}.get(str(self.type), str(self.type))


COLUMNS = (
    Column("frame", pa.int64(), "", "the master's frame number, after that frame's step"),
    Column("time", pa.float64(), "s", "simulation time: the sum of the logged dt since the "
           "run's start or its last reset"),
    Column("id", pa.uint64(), "", "birth index: particles appended to the stream before "
           "this one since the run started"),
    Column("class", pa.string(), "", "the particle class's name in the scene"),
    Column("x", pa.float64(), "m", "world position (pos + pos_low + the scene's origin)"),
    Column("y", pa.float64(), "m", "world position"),
    Column("z", pa.float64(), "m", "world position"),
    Column("u", pa.float32(), "m/s", "velocity, as the particle record holds it"),
    Column("v", pa.float32(), "m/s", "velocity"),
    Column("w", pa.float32(), "m/s", "velocity"),
)

# key-value metadata; the first group is known when the file opens, the second at its close
METADATA_AT_OPEN = ("cavesim_version", "scene", "scene_digest", "scene_origin",
                    "trajectories", "every", "stride")
METADATA_AT_CLOSE = ("frames", "ambiguous_drops")
SORT_ORDER = ("frame", "id")


def arrow_schema(metadata: dict[str, str] | None = None) -> pa.Schema:
    """The file's Arrow schema; each field's unit is in its own metadata."""
    fields = [pa.field(c.name, c.type, nullable=False,
                       metadata={"unit": c.unit} if c.unit else None) for c in COLUMNS]
    return pa.schema(fields, metadata=metadata)
