"""cavesim's own .npz flow field: an array "velocity" (nz, ny, nx, 3), or with an array
"times" (nt,) in seconds a series (nt, nz, ny, nx, 3), x varying fastest as in the 3D
texture. Its layout is read from the .npy headers and held to the limits (nodes per axis,
nodes of a grid, snapshots, nodes of a series) before any array is: the scene loader reads
the layout alone, a node the arrays too (`cavesim.core.fields.grid`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from cavesim.core.errors import FieldError
from cavesim.core.fields.npz_archive import NpzArchive
from cavesim.core.limits import (
    FIELD_RESOLUTION_RANGE,
    MAX_FIELD_NODES,
    MAX_FIELD_SERIES_NODES,
    MAX_FIELD_SNAPSHOTS,
)

LOW, HIGH = FIELD_RESOLUTION_RANGE
ALLOWED = (f"must be a .nc (NetCDF) or .vti (VTK image) file, or an .npz holding an array "
           f"'velocity' of shape (nz, ny, nx, 3), each n in {LOW}..{HIGH}, nx*ny*nz <= "
           f"{MAX_FIELD_NODES} (a series: (nt, nz, ny, nx, 3) with 'times', nt <= "
           f"{MAX_FIELD_SNAPSHOTS}, nt*nx*ny*nz <= {MAX_FIELD_SERIES_NODES})")


@dataclass(frozen=True)
class NpzLayout:
    """What an .npz field's headers (and its times) say of it."""

    shape: tuple[int, ...]  # of "velocity": (nz, ny, nx, 3), or (nt, nz, ny, nx, 3)
    times: tuple[float, ...] | None  # s from the first snapshot; None: steady

    @property
    def resolution(self) -> tuple[int, int, int]:
        """Nodes per axis as (nx, ny, nz)."""
        nz, ny, nx = self.shape[-4:-1]
        return nx, ny, nz


def npz_layout(path: Path) -> NpzLayout:
    """The layout of the .npz field at `path`, checked against the limits; FieldError names
    the file, what it holds and what is allowed."""
    with _opened(path) as archive:
        return _layout(archive)


def read_npz_field(path: Path) -> tuple[np.ndarray, tuple[float, ...]]:
    """The velocity (nt, nz, ny, nx, 3) and times of the .npz field at `path`, read once
    its layout is within the limits (a steady field: one snapshot at 0.0)."""
    with _opened(path) as archive:
        layout = _layout(archive)
        velocity = archive.array("velocity", math.prod(layout.shape))
    return (velocity if layout.times else velocity[np.newaxis]), layout.times or (0.0,)


def _opened(path: Path) -> NpzArchive:
    try:
        return NpzArchive(path)
    except FieldError as e:  # no .npz at all: say what the file may be
        raise FieldError(f"{e}; {ALLOWED}") from e.__cause__ or e


def _layout(archive: NpzArchive) -> NpzLayout:
    path = archive.path
    if "velocity" not in archive.names:
        raise FieldError(f"{path}: missing array 'velocity'; the archive holds "
                         f"{list(archive.names)}; {ALLOWED}")
    shape = archive.shape("velocity")
    series = "times" in archive.names
    grid = shape[1:] if series else shape
    if series and shape and shape[0] > MAX_FIELD_SNAPSHOTS:
        raise FieldError(f"{path}: array 'velocity' of shape {shape} holds {shape[0]:,} "
                         f"snapshots; at most MAX_FIELD_SNAPSHOTS = {MAX_FIELD_SNAPSHOTS} are "
                         f"allowed (a series' snapshots are stacked in one 3D texture)")
    snapshots = shape[0] if series and shape else 1
    if (len(grid) != 4 or grid[3] != 3 or not all(LOW <= n <= HIGH for n in grid[:3])
            or math.prod(grid[:3]) > MAX_FIELD_NODES
            or snapshots * math.prod(grid[:3]) > MAX_FIELD_SERIES_NODES):
        raise FieldError(f"{path}: array 'velocity' has shape {shape}; {ALLOWED}")
    times = _seconds(path, archive.array("times", MAX_FIELD_SNAPSHOTS), shape) \
        if series else None
    return NpzLayout(shape, times)


def _seconds(path: Path, times: np.ndarray, velocity_shape: tuple[int, ...]
             ) -> tuple[float, ...]:
    """An .npz series' "times" (nt,) as seconds from the first: finite, strictly increasing,
    one per snapshot of its "velocity" (nt, nz, ny, nx, 3)."""
    if (times.ndim != 1 or times.dtype.kind not in "iuf" or not np.isfinite(times).all()
            or len(times) < 2 or len(velocity_shape) != 5 or velocity_shape[0] != len(times)
            or not (np.diff(times.astype(np.float64)) > 0).all()):
        raise FieldError(f"{path}: array 'times' has shape {times.shape} and values "
                         f"{times.ravel()[:6].tolist()!r} with 'velocity' of shape "
                         f"{tuple(velocity_shape)}; expected 2 or more finite, strictly increasing "
                         "seconds, one per snapshot of a 'velocity' (nt, nz, ny, nx, 3)")
    return tuple((times.astype(np.float64) - float(times[0])).tolist())
