"""The flow field on the CPU: builds the velocity grids that the GPU samples as a 3D texture.

Data flow: the scene loader gives a `Field`; `build_series` turns it into a `FieldSeries`
once per scene: one `FieldGrid` for a steady field (an analytic model evaluated at the
nodes, or a file checked at the door), or one per snapshot of a time series. The GL engine
uploads `series.texels().tobytes()` as a 3-component 3D texture (the nodes, or for a cubic
interpolation the texels of `cavesim.core.fields.interpolation`; a series' snapshots stacked along
z), and every frame the drag stage samples it. `sample_field` is the numpy twin of that
shader lookup on one snapshot; `cavesim.core.fields.snapshot_time` says how snapshots mix in time.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

from cavesim.core.errors import FieldError
from cavesim.core.fields.analytic import MODELS, rotating_velocity
from cavesim.core.fields.flow_files import FLOW_FILE_SUFFIXES, read_flow_file
from cavesim.core.fields.interpolation import is_cubic, texels, weights
from cavesim.core.fields.npz_field import read_npz_field
from cavesim.core.fields.regular_grid import cells, check_box, float_grid, index_scale, mix
from cavesim.core.limits import FIELD_RESOLUTION_RANGE
from cavesim.core.scene.model import Field, FieldInterpolation, FieldKind, OutOfDomain


@dataclass(frozen=True, eq=False)
class FieldGrid:
    """Flow velocity (m/s) at the nodes of a regular grid whose corner nodes are the box corners.

    `velocity[k, j, i]` is the flow at box_min + (i, j, k) · (box_max − box_min) / (res − 1).
    It is stored float32, C-contiguous and read-only. `texels` is what `interpolation` samples
    (`velocity` itself for trilinear), so `texels.tobytes()` is the data of a 3D texture of
    size `texture_size` with 3 components.
    """

    velocity: np.ndarray  # (nz, ny, nx, 3)
    box_min: tuple[float, float, float]
    box_max: tuple[float, float, float]
    interpolation: FieldInterpolation = FieldInterpolation.TRILINEAR
    texels: np.ndarray = dataclasses.field(init=False, repr=False)  # + 2 per axis for a cubic

    def __post_init__(self) -> None:
        velocity = np.ascontiguousarray(self.velocity, dtype=np.float32).view()
        if velocity.ndim != 4 or velocity.shape[3] != 3 or min(velocity.shape[:3]) < 2:
            raise FieldError(f"velocity grid has shape {velocity.shape}, expected (nz, ny, nx, 3)"
                             " with at least 2 nodes per axis")
        velocity.flags.writeable = False
        box_min, box_max = check_box(self.box_min, self.box_max, 3, "field")
        interpolation = FieldInterpolation(self.interpolation)
        grid_texels = texels(velocity, interpolation)  # `velocity` itself for trilinear
        grid_texels.flags.writeable = False
        object.__setattr__(self, "velocity", velocity)
        object.__setattr__(self, "box_min", box_min)
        object.__setattr__(self, "box_max", box_max)
        object.__setattr__(self, "interpolation", interpolation)
        object.__setattr__(self, "texels", grid_texels)

    @property
    def resolution(self) -> tuple[int, int, int]:
        """Nodes per axis as (nx, ny, nz)."""
        nz, ny, nx, _ = self.velocity.shape
        return nx, ny, nz

    @property
    def texture_size(self) -> tuple[int, int, int]:
        """Texels per axis as (nx, ny, nz): the resolution, plus the ghosts of a cubic."""
        nz, ny, nx, _ = self.texels.shape
        return nx, ny, nz

    @property
    def index_scale(self) -> np.ndarray:
        """Grid index per metre on each axis, float32: the shader's uniform of this name."""
        return index_scale(self.box_min, self.box_max, self.resolution)


@dataclass(frozen=True, eq=False)
class FieldSeries:
    """A field's snapshots on one grid and the times they hold at (s from the first,
    increasing); one snapshot at (0.0,) is a steady field."""

    snapshots: tuple[FieldGrid, ...]
    times: tuple[float, ...] = (0.0,)

    def __post_init__(self) -> None:
        first = self.snapshots[0]
        if len(self.times) != len(self.snapshots):
            raise FieldError(f"{len(self.snapshots)} snapshots with {len(self.times)} times; "
                             "expected one time each")
        times = np.asarray(self.times, dtype=np.float64)
        if not np.isfinite(times).all() or (np.diff(times) <= 0).any():
            raise FieldError(f"snapshot times {list(self.times)[:6]}...: expected finite and "
                             "strictly increasing")
        if any((g.resolution, g.box_min, g.box_max, g.interpolation) != (
                first.resolution, first.box_min, first.box_max, first.interpolation)
                for g in self.snapshots):
            raise FieldError("a time series' snapshots must share one grid and interpolation")

    @property
    def first(self) -> FieldGrid:
        """Snapshot 0: its grid (box, resolution, interpolation) is every snapshot's."""
        return self.snapshots[0]

    @property
    def steady(self) -> bool:
        return len(self.snapshots) == 1

    @property
    def texture_size(self) -> tuple[int, int, int]:
        """Texels per axis of the stacked texture: a snapshot's, z times the snapshots."""
        nx, ny, nz = self.first.texture_size
        return nx, ny, nz * len(self.snapshots)

    def texels(self) -> np.ndarray:
        """Every snapshot's texels stacked along z, snapshot 0 first (a new array)."""
        return np.concatenate([g.texels for g in self.snapshots], axis=0)


def build_series(field: Field) -> FieldSeries:
    """The snapshots of a scene's field: a file's (NetCDF holds a time series; .npz with
    "times"), a rotating flow's, or the one grid of a steady field (`build_field`)."""
    kind = FieldKind(field.kind)
    if kind is FieldKind.ROTATING:
        box_min, box_max = check_box(field.box_min, field.box_max, 3, "field")
        nx, ny, nz = field.resolution
        grids = tuple(FieldGrid(np.broadcast_to(rotating_velocity(t, field.params),
                                                (nz, ny, nx, 3)).astype(np.float32),
                                box_min, box_max, field.interpolation)
                      for t in field.times)
        return FieldSeries(grids, field.times)
    if kind is FieldKind.FILE and field.times is not None:
        box_min, box_max = check_box(field.box_min, field.box_max, 3, "field")
        velocity, times = _read_flow(field)
        return FieldSeries(tuple(FieldGrid(v, box_min, box_max, field.interpolation)
                                 for v in velocity), times)
    return FieldSeries((build_field(field),))


def build_field(field: Field) -> FieldGrid:
    """The grid of a steady field: its file's for FILE, else the analytic model at the nodes.

    For FILE the resolution comes from the file and `field.resolution` is not used; the box
    is the field's, as the loader read it and the scene's origin moved it.
    """
    kind = FieldKind(field.kind)
    if field.times is not None:
        raise FieldError(f"the {kind.value} field is a time series of {len(field.times)} "
                         "snapshots; its grids come from build_series")
    box_min, box_max = check_box(field.box_min, field.box_max, 3, "field")
    if kind is FieldKind.FILE:
        velocity, times = _read_flow(field)
        if len(times) > 1:
            raise FieldError(f"{field.file}: holds {len(times)} snapshots, but the field was "
                             "given as steady (a scene the loader did not read)")
        return FieldGrid(velocity[0], box_min, box_max, field.interpolation)
    res = tuple(field.resolution)
    low, high = FIELD_RESOLUTION_RANGE
    in_range = (isinstance(n, int | np.integer) and low <= n <= high for n in res)
    if len(res) != 3 or not all(in_range):
        raise FieldError(f"field resolution must be 3 integers in [{low}, {high}], "
                         f"got {field.resolution!r}")
    nx, ny, nz = res
    x = np.linspace(box_min[0], box_max[0], nx)[None, None, :]
    y = np.linspace(box_min[1], box_max[1], ny)[None, :, None]
    z = np.linspace(box_min[2], box_max[2], nz)[:, None, None]
    velocity = MODELS[kind](x, y, z, field.params)  # float64, cast to float32 once below
    return FieldGrid(velocity.astype(np.float32), box_min, box_max, field.interpolation)


def sample_field(grid: FieldGrid, points, out_of_domain: OutOfDomain,
                 dtype=np.float64) -> np.ndarray:
    """The grid's interpolated flow at world points (..., 3): the numpy twin of the shader's
    manual lookup, with the grid's interpolation.

    Everything is computed in `dtype` (float64 reference, or float32 to mirror the GPU); box
    corners and points are rounded to `dtype` first. Per axis, with res the nodes on it:
      f  = (p − box_min) / (box_max − box_min) · (res − 1)   (left to right)
      f  = clamp(f, 0, res − 1)
      i0 = min(floor(f), res − 2),  t = f − i0
    TRILINEAR: with mix(a, b, t) = a·(1 − t) + b·t and c_zyx = velocity[i0z+z, i0y+y, i0x+x]:
      v = mix(mix(mix(c000, c001, tx), mix(c010, c011, tx), ty),
              mix(mix(c100, c101, tx), mix(c110, c111, tx), ty), tz).
    CATMULL_ROM, BSPLINE: v = sum over a, b, c in 0..3 of
      wz[c] · wy[b] · wx[a] · texels[i0z + c, i0y + b, i0x + a]
    with the weights and texels of `cavesim.core.fields.interpolation`.
    CLAMP: as above (outside the box, the flow of the nearest boundary point).
    ZERO: 0 where p lies outside the closed box on any axis, else as above.
    A point with a NaN coordinate gives NaN.
    """
    out_of_domain = OutOfDomain(out_of_domain)
    p = np.asarray(points, dtype=dtype)
    if p.shape[-1:] != (3,):
        raise ValueError(f"points must have shape (..., 3), got {p.shape}")
    flat = p.reshape(-1, 3)
    lo, hi = np.asarray(grid.box_min, dtype), np.asarray(grid.box_max, dtype)
    i0, t, _ = cells(flat, lo, hi, grid.resolution, dtype)
    interpolate = _cubic if is_cubic(grid.interpolation) else _trilinear
    out = interpolate(grid, i0, t, dtype)
    if out_of_domain is OutOfDomain.ZERO:
        out[outside_box(grid, flat, dtype)] = 0
    out[np.isnan(flat).any(axis=1)] = np.nan
    return out.reshape(p.shape)


def outside_box(grid: FieldGrid, points, dtype=np.float64) -> np.ndarray:
    """Whether each point (N, 3) lies outside the grid's closed box, as `sample_field`'s
    ZERO sees it; (N,) bool, NaN not outside."""
    p = np.asarray(points, dtype=dtype)
    lo, hi = np.asarray(grid.box_min, dtype), np.asarray(grid.box_max, dtype)
    return ((p < lo) | (p > hi)).any(axis=1)


def _trilinear(grid: FieldGrid, i0: np.ndarray, t: np.ndarray, dtype) -> np.ndarray:
    (ix, iy, iz), (tx, ty, tz) = i0.T, (t[:, a, None] for a in range(3))
    velocity = grid.velocity

    def corner(dz: int, dy: int, dx: int) -> np.ndarray:
        return velocity[iz + dz, iy + dy, ix + dx].astype(dtype)

    near = mix(mix(corner(0, 0, 0), corner(0, 0, 1), tx),
                mix(corner(0, 1, 0), corner(0, 1, 1), tx), ty)
    far = mix(mix(corner(1, 0, 0), corner(1, 0, 1), tx),
               mix(corner(1, 1, 0), corner(1, 1, 1), tx), ty)
    return mix(near, far, tz)


def _cubic(grid: FieldGrid, i0: np.ndarray, t: np.ndarray, dtype) -> np.ndarray:
    """The 4 x 4 x 4 texels of each point's cell (texel i0 holds node i0 − 1), weighted."""
    blocks = sliding_window_view(grid.texels, (4, 4, 4), axis=(0, 1, 2))  # a view, no copy
    block = blocks[i0[:, 2], i0[:, 1], i0[:, 0]].reshape(-1, 3, 64).astype(dtype)
    wx, wy, wz = (np.stack(weights(t[:, a], grid.interpolation), axis=1) for a in range(3))
    weight = (wz[:, :, None, None] * wy[:, None, :, None] * wx[:, None, None, :]).reshape(-1, 64)
    return np.matmul(block, weight[:, :, None])[:, :, 0]


def save_field(path, grid: FieldGrid) -> None:
    """Write `grid` as an .npz with "velocity" (nz, ny, nx, 3), "box_min" and "box_max"."""
    with open(path, "wb") as file:  # an open file keeps np.savez from appending ".npz"
        np.savez(file, velocity=grid.velocity, box_min=np.asarray(grid.box_min),
                 box_max=np.asarray(grid.box_max))


def _read_flow(field: Field) -> tuple[np.ndarray, tuple[float, ...]]:
    """A FILE field's velocity (nt, nz, ny, nx, 3) and times.

    Not its box: the loader read that from the file once (or from the scene, for an .npz),
    and `[simulation] origin` moved it with every other coordinate; the file's own box is
    in world coordinates.
    """
    if field.file is None:
        raise FieldError("field of kind 'file' names no file")
    path = Path(field.file)
    if path.suffix.lower() in FLOW_FILE_SUFFIXES:
        flow = read_flow_file(path, field.named_variables, field.velocity_units,
                              field.length_units, field.time_units)
        return flow.velocity, flow.times
    return _load_field_file(path)


def _load_field_file(path: Path) -> tuple[np.ndarray, tuple[float, ...]]:
    """An .npz field's velocity (nt, nz, ny, nx, 3) and times (`npz_field`), each snapshot
    checked (dtype, finiteness) as float32."""
    velocity, times = read_npz_field(path)
    series = len(times) > 1
    return np.stack([float_grid(path, f"velocity[{n}]" if series else "velocity", snapshot,
                                "(nz, ny, nx, 3)", FIELD_RESOLUTION_RANGE[1], components=3)
                     for n, snapshot in enumerate(velocity)]), times
