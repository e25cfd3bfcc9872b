"""trajectories.parquet: its columns and metadata, written so that a killed run or a full
disk never leaves a file that claims to be complete, and read back for pandas and xarray.

One table of columns (`COLUMNS`) is what the writer, the loaders and the docs test read.
Rows go to `.trajectories.parquet.partial` beside the final name, in row groups of
ROW_GROUP_ROWS rows (the writer holds at most one group in memory); `finish` writes the
footer with the closing metadata and renames the file to its name. A run that is killed
or fails leaves no trajectories.parquet (`abort` removes the partial file; a SIGKILL may
leave the partial one, which has no footer and no reader opens). Read back, the file is a
pandas table as written, or an xarray dataset with one row per particle and one column per
observation (`(trajectory, obs)`, as OceanParcels writes its output).

The recorder (`recording.py`) hands it one table of rows per recorded frame.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from cavesim.core.output import writing

ROW_GROUP_ROWS = 65_536


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


class TrajectoryFile:
    """An open trajectories file: `write` tables of its schema, then `finish` or `abort`."""

    def __init__(self, path: Path, metadata: dict[str, str]) -> None:
        self.path = Path(path)
        self.partial = self.path.with_name(f".{self.path.name}.partial")
        self.schema = arrow_schema(metadata)
        self._pending: list[pa.Table] = []
        self._pending_rows = 0
        self._named = False
        with writing(self.partial):
            self._writer = pq.ParquetWriter(self.partial, self.schema, compression="zstd")

    def write(self, table: pa.Table) -> None:
        self._pending.append(table)
        self._pending_rows += table.num_rows
        if self._pending_rows >= ROW_GROUP_ROWS:
            self._flush()

    def _flush(self) -> None:
        if not self._pending:
            return
        table = pa.concat_tables(self._pending).replace_schema_metadata(self.schema.metadata)
        self._pending, self._pending_rows = [], 0
        with writing(self.partial):
            self._writer.write_table(table, row_group_size=ROW_GROUP_ROWS)

    def finish(self, metadata: dict[str, str]) -> Path:
        """Write the last rows and the footer (with `metadata` added) and give the file its
        name."""
        try:
            self._flush()
            self._writer.add_key_value_metadata(metadata)
            with writing(self.partial):
                self._writer.close()
                os.replace(self.partial, self.path)
            self._named = True
        except BaseException:
            self.abort()
            raise
        return self.path

    def abort(self) -> None:
        """Drop the file, unless `finish` named it: nothing is left under either name."""
        if self._named:
            return
        try:
            self._writer.close()
        except (OSError, pa.ArrowException):  # the file is removed whatever its state
            pass
        self.partial.unlink(missing_ok=True)


TRACK_COLUMNS = ("frame", "time", "x", "y", "z", "u", "v", "w")  # one value per observation
FILL = {"frame": -1}  # where a track has ended; floats get NaN


def file_metadata(path: Path) -> dict[str, str]:
    """The file's key-value metadata: those known when it opened and those its close wrote
    (`METADATA_AT_OPEN`, `METADATA_AT_CLOSE`)."""
    return {k.decode(): v.decode() for k, v in (pq.read_metadata(path).metadata or {}).items()
            if not k.startswith(b"ARROW:")}


def read_table(path: Path):
    """The file as a pandas DataFrame, rows in (frame, id) order; `attrs`: its metadata."""
    frame = pq.read_table(path).to_pandas()
    frame.attrs = file_metadata(path)
    return frame


def to_dataset(path: Path):
    """The file as an xarray Dataset over (trajectory, obs): `trajectory` is the birth
    index, `obs` counts a particle's rows from its first; a shorter track is padded with NaN
    (frame: -1). The file's key-value metadata are its attributes, each column's unit its
    variable's `units`."""
    import xarray as xr

    table = pq.read_table(path)
    frame = table.to_pandas().sort_values(["id", "frame"], kind="stable")
    ids, first, counts = np.unique(frame["id"].to_numpy(), return_index=True,
                                   return_counts=True)
    obs = np.arange(len(frame)) - np.repeat(first, counts)
    row = np.repeat(np.arange(len(ids)), counts)
    units = {c.name: c.unit for c in COLUMNS}
    data = {}
    for name in TRACK_COLUMNS:
        values = frame[name].to_numpy()
        fill = FILL.get(name, np.nan)
        grid = np.full((len(ids), counts.max(initial=0)), fill, dtype=values.dtype)
        grid[row, obs] = values
        data[name] = (("trajectory", "obs"), grid, {"units": units[name]} if units[name] else {})
    data["class"] = ("trajectory", frame["class"].to_numpy()[first].astype(str))
    return xr.Dataset(data, coords={"trajectory": ids}, attrs=file_metadata(path))
