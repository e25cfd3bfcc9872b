"""trajectories.parquet read back: a pandas table as written, or an xarray dataset with one
row per particle and one column per observation (`(trajectory, obs)`, as OceanParcels
writes its output)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pyarrow.parquet as pq

from cavesim.core.trajectories.columns import COLUMNS

TRACK_COLUMNS = ("frame", "time", "x", "y", "z", "u", "v", "w")  # one value per observation
FILL = {"frame": -1}  # where a track has ended; floats get NaN


def file_metadata(path: Path) -> dict[str, str]:
    """The file's key-value metadata: those known when it opened and those its close wrote
    (`columns.METADATA_AT_OPEN`, `METADATA_AT_CLOSE`)."""
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
