"""The flow field on the CPU: builds the velocity grid that the GPU samples as a 3D texture.

Data flow: the scene loader gives a `Field`; `build_field` turns it into a `FieldGrid` once
per scene (an analytic model evaluated at the nodes, or an .npz file checked at the door);
the GL engine uploads `grid.velocity.tobytes()` as a 3-component 3D texture, and every frame
the drag stage samples it. `sample_field` is the numpy twin of that shader lookup.
"""

from __future__ import annotations

import math
import zipfile
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from cavesim.errors import FieldError
from cavesim.scene.model import Field, FieldKind, OutOfDomain

MAX_FIELD_NODES = 256  # per axis: 256³ nodes × 3 × float32 is already 200 MB of texture
_BOX_RTOL = 1e-9


@dataclass(frozen=True, eq=False)
class FieldGrid:
    """Flow velocity (m/s) at the nodes of a regular grid whose corner nodes are the box corners.

    `velocity[k, j, i]` is the flow at box_min + (i, j, k) · (box_max − box_min) / (res − 1).
    It is stored float32, C-contiguous and read-only, so `velocity.tobytes()` is the data of a
    3D texture of size (nx, ny, nz) with 3 components.
    """

    velocity: np.ndarray  # (nz, ny, nx, 3)
    box_min: tuple[float, float, float]
    box_max: tuple[float, float, float]

    def __post_init__(self) -> None:
        velocity = np.ascontiguousarray(self.velocity, dtype=np.float32).view()
        if velocity.ndim != 4 or velocity.shape[3] != 3 or min(velocity.shape[:3]) < 2:
            raise FieldError(f"velocity grid has shape {velocity.shape}, expected (nz, ny, nx, 3)"
                             " with at least 2 nodes per axis")
        velocity.flags.writeable = False
        box_min, box_max = _check_box(self.box_min, self.box_max, 3, "field")
        object.__setattr__(self, "velocity", velocity)
        object.__setattr__(self, "box_min", box_min)
        object.__setattr__(self, "box_max", box_max)

    @property
    def resolution(self) -> tuple[int, int, int]:
        """Nodes per axis as (nx, ny, nz)."""
        nz, ny, nx, _ = self.velocity.shape
        return nx, ny, nz


def build_field(field: Field) -> FieldGrid:
    """The grid of a scene's field: the .npz file for FILE, else the analytic model at the nodes.

    For FILE the resolution comes from the file and `field.resolution` is not used.
    """
    kind = FieldKind(field.kind)
    box_min, box_max = _check_box(field.box_min, field.box_max, 3, "field")
    if kind is FieldKind.FILE:
        if field.file is None:
            raise FieldError("field of kind 'file' names no file")
        return _load_field_file(Path(field.file), box_min, box_max)
    res = tuple(field.resolution)
    in_range = (isinstance(n, int | np.integer) and 2 <= n <= MAX_FIELD_NODES for n in res)
    if len(res) != 3 or not all(in_range):
        raise FieldError(f"field resolution must be 3 integers in [2, {MAX_FIELD_NODES}], "
                         f"got {field.resolution!r}")
    nx, ny, nz = res
    x = np.linspace(box_min[0], box_max[0], nx)[None, None, :]
    y = np.linspace(box_min[1], box_max[1], ny)[None, :, None]
    z = np.linspace(box_min[2], box_max[2], nz)[:, None, None]
    velocity = _MODELS[kind](x, y, z, field.params)  # float64, cast to float32 once below
    return FieldGrid(velocity.astype(np.float32), box_min, box_max)


def uniform_velocity(x, y, z, params: Mapping[str, object]) -> np.ndarray:
    """The constant flow params["velocity"] = (vx, vy, vz) at every point; shape (..., 3)."""
    return _stack((x, y, z), *_param(params, "velocity", sizes=(3,)))


def vortex_velocity(x, y, z, params: Mapping[str, object]) -> np.ndarray:
    """Lamb–Oseen vortex about the vertical axis through params["center"] (x, y); (..., 3).

    v_θ(r) = Γ/(2π r) · (1 − exp(−r²/rc²)), counter-clockwise seen from above for Γ > 0, 0 on
    the axis; plus the constant vertical flow `axial_speed` (default 0). Params: center,
    circulation (Γ), core_radius (rc > 0), axial_speed.
    """
    cx, cy = _param(params, "center", sizes=(2, 3))[:2]
    gamma = _param(params, "circulation")
    core = _param(params, "core_radius", positive=True)
    axial = _param(params, "axial_speed", default=0.0)
    dx, dy = np.asarray(x, np.float64) - cx, np.asarray(y, np.float64) - cy
    r2 = dx * dx + dy * dy
    # (1 − exp(−r²/rc²)) / r², whose limit on the axis is 1/rc²; expm1 keeps it exact near 0
    safe_r2 = np.where(r2 > 0, r2, 1.0)
    shape = np.where(r2 > 0, -np.expm1(-r2 / core**2) / safe_r2, 1.0 / core**2)
    scale = gamma / (2 * math.pi) * shape
    return _stack((x, y, z), -scale * dy, scale * dx, axial)


def downwash_velocity(x, y, z, params: Mapping[str, object]) -> np.ndarray:
    """A simple rotor downwash: a hand-made shape, not momentum theory; (..., 3).

    Params: rotor disk of radius R = `rotor_radius` centred at `rotor_center` (x, y, z),
    `induced_velocity` v_i, ground at `ground_height` (default 0). With r the horizontal
    distance from the rotor axis, h the height above ground, decay = exp(−h / (0.25 R)) and
    footprint = exp(−(r/R)⁴):
    Between ground and disk: w = −v_i · footprint · (1 − decay), and the radial wall flow
    u_r = v_i · R / max(r, R) · decay · smoothstep(0.5 R, R, r).
    Above the disk: weak inflow w = −0.5 v_i · footprint · exp(−(z − z_rotor)/R), no u_r.
    Below ground: 0. Not divergence-free, and w jumps by 0.5 v_i · footprint at the disk plane.
    """
    cx, cy, cz = _param(params, "rotor_center", sizes=(3,))
    radius = _param(params, "rotor_radius", positive=True)
    v_i = _param(params, "induced_velocity")
    ground = _param(params, "ground_height", default=0.0)
    if cz <= ground:
        raise FieldError(f"downwash rotor_center z = {cz} must be above ground_height = {ground}")
    dx, dy = np.asarray(x, np.float64) - cx, np.asarray(y, np.float64) - cy
    z = np.asarray(z, np.float64)
    r = np.hypot(dx, dy)
    h = z - ground
    footprint = np.exp(-((r / radius) ** 4))
    decay = np.exp(-np.maximum(h, 0.0) / (0.25 * radius))
    below, above = (h >= 0) & (z <= cz), z > cz
    w_below = -v_i * footprint * (1.0 - decay)
    w_above = -0.5 * v_i * footprint * np.exp(-np.maximum(z - cz, 0.0) / radius)
    w = np.where(below, w_below, np.where(above, w_above, 0.0))
    s = np.clip((r - 0.5 * radius) / (0.5 * radius), 0.0, 1.0)
    ramp = s * s * (3.0 - 2.0 * s)  # smoothstep(0.5 R, R, r)
    u_r = np.where(below, v_i * radius / np.maximum(r, radius) * decay * ramp, 0.0)
    safe_r = np.where(r > 0, r, 1.0)  # u_r is 0 for r < R/2, so the axis needs no direction
    return _stack((x, y, z), u_r * dx / safe_r, u_r * dy / safe_r, w)


_MODELS = {
    FieldKind.UNIFORM: uniform_velocity,
    FieldKind.VORTEX: vortex_velocity,
    FieldKind.DOWNWASH: downwash_velocity,
}


def sample_field(grid: FieldGrid, points, out_of_domain: OutOfDomain,
                 dtype=np.float64) -> np.ndarray:
    """Trilinear flow at world points (..., 3): the numpy twin of the shader's manual lookup.

    Everything is computed in `dtype` (float64 reference, or float32 to mirror the GPU); box
    corners and points are rounded to `dtype` first. Per axis, with res the nodes on it:
      f  = (p − box_min) / (box_max − box_min) · (res − 1)   (left to right)
      f  = clamp(f, 0, res − 1)
      i0 = min(floor(f), res − 2),  t = f − i0
    and with mix(a, b, t) = a·(1 − t) + b·t and c_zyx = velocity[i0z+z, i0y+y, i0x+x]:
      v = mix(mix(mix(c000, c001, tx), mix(c010, c011, tx), ty),
              mix(mix(c100, c101, tx), mix(c110, c111, tx), ty), tz).
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
    i0, t, _ = _cells(flat, lo, hi, grid.resolution, dtype)
    (ix, iy, iz), (tx, ty, tz) = i0.T, (t[:, a, None] for a in range(3))
    velocity = grid.velocity

    def corner(dz: int, dy: int, dx: int) -> np.ndarray:
        return velocity[iz + dz, iy + dy, ix + dx].astype(dtype)

    near = _mix(_mix(corner(0, 0, 0), corner(0, 0, 1), tx),
                _mix(corner(0, 1, 0), corner(0, 1, 1), tx), ty)
    far = _mix(_mix(corner(1, 0, 0), corner(1, 0, 1), tx),
               _mix(corner(1, 1, 0), corner(1, 1, 1), tx), ty)
    out = _mix(near, far, tz)
    if out_of_domain is OutOfDomain.ZERO:
        out[((flat < lo) | (flat > hi)).any(axis=1)] = 0
    out[np.isnan(flat).any(axis=1)] = np.nan
    return out.reshape(p.shape)


def save_field(path, grid: FieldGrid) -> None:
    """Write `grid` as an .npz with "velocity" (nz, ny, nx, 3), "box_min" and "box_max"."""
    with open(path, "wb") as file:  # an open file keeps np.savez from appending ".npz"
        np.savez(file, velocity=grid.velocity, box_min=np.asarray(grid.box_min),
                 box_max=np.asarray(grid.box_max))


def _load_field_file(path: Path, box_min, box_max) -> FieldGrid:
    arrays = _read_npz(path, required=("velocity",), optional=("box_min", "box_max"))
    velocity = _float_grid(path, "velocity", arrays["velocity"], "(nz, ny, nx, 3)",
                           MAX_FIELD_NODES, components=3)
    for name, scene_corner in (("box_min", box_min), ("box_max", box_max)):
        if name not in arrays:
            continue
        file_corner = _corner(path, name, arrays[name], 3)
        extents = (b - a for a, b in zip(box_min, box_max, strict=True))
        if not all(math.isclose(f, s, rel_tol=_BOX_RTOL, abs_tol=_BOX_RTOL * e)
                   for f, s, e in zip(file_corner, scene_corner, extents, strict=True)):
            raise FieldError(f"{path}: array {name!r} is {file_corner}, but the scene's field box "
                             f"has {name} = {scene_corner}; they must agree to 1e-9 relative")
    return FieldGrid(velocity, box_min, box_max)


# Shared with heightfield.py: reading and checking grids at the file edge, and cell lookup.


def _read_npz(path: Path, required: tuple[str, ...], optional: tuple[str, ...] = ()) -> dict:
    """The named arrays of an .npz archive; any read or format failure becomes a FieldError."""
    errors = (OSError, ValueError, EOFError, zipfile.BadZipFile)
    try:
        archive = np.load(path, allow_pickle=False)
    except errors as e:
        raise FieldError(f"{path}: cannot read as an .npz archive: {e}") from e
    if not isinstance(archive, np.lib.npyio.NpzFile):
        raise FieldError(f"{path}: is a single .npy array, expected an .npz archive with "
                         f"arrays {required + optional}")
    with archive:
        for name in required:
            if name not in archive.files:
                raise FieldError(f"{path}: missing array {name!r}; the archive holds "
                                 f"{archive.files}, expected {required} (optional {optional})")
        try:
            return {name: archive[name] for name in required + optional if name in archive.files}
        except errors as e:
            raise FieldError(f"{path}: cannot read the arrays {required + optional}: {e}") from e


def _float_grid(path: Path, name: str, array: np.ndarray, layout: str, max_nodes: int,
                components: int = 0) -> np.ndarray:
    """`array` as C-contiguous float32 after checking dtype, shape, size and finiteness."""
    where = f"{path}: array {name!r}"
    if array.dtype.kind != "f":
        raise FieldError(f"{where} has dtype {array.dtype}, expected float16, float32 or float64")
    nodes = array.shape[:-1] if components else array.shape
    if array.ndim != layout.count(",") + 1 or (components and array.shape[-1] != components):
        raise FieldError(f"{where} has shape {array.shape}, expected {layout}")
    if not all(2 <= n <= max_nodes for n in nodes):
        raise FieldError(f"{where} has shape {array.shape}, expected {layout} with 2 to "
                         f"{max_nodes} nodes per axis")
    with np.errstate(over="ignore"):
        grid = np.ascontiguousarray(array, dtype=np.float32)
    bad = ~np.isfinite(grid)
    if bad.any():
        first = tuple(int(i) for i in np.argwhere(bad)[0])
        raise FieldError(f"{where} has {int(bad.sum())} non-finite value(s) in float32 (NaN, inf "
                         f"or beyond the float32 range), the first at index {first}")
    return grid


def _corner(path: Path, name: str, array: np.ndarray, n: int) -> tuple[float, ...]:
    if array.shape != (n,) or array.dtype.kind not in "iuf" or not np.isfinite(array).all():
        raise FieldError(f"{path}: array {name!r} has shape {array.shape}, dtype {array.dtype} "
                         f"and values {array.ravel()[:8].tolist()!r}, expected {n} finite numbers")
    return tuple(float(v) for v in array)


def _check_box(box_min, box_max, n: int, what: str) -> tuple[tuple[float, ...], ...]:
    """The box corners as float tuples; FieldError unless n finite numbers, box_max > box_min."""
    try:
        lo, hi = tuple(float(v) for v in box_min), tuple(float(v) for v in box_max)
    except (TypeError, ValueError) as e:
        raise FieldError(f"{what} box corners must be numbers, got box_min={box_min!r}, "
                         f"box_max={box_max!r}") from e
    if (len(lo), len(hi)) != (n, n) or not all(map(math.isfinite, lo + hi)) \
            or not all(a < b for a, b in zip(lo, hi, strict=True)):
        raise FieldError(f"{what} box corners must be {n} finite numbers each with box_max > "
                         f"box_min on every axis, got box_min={lo}, box_max={hi}")
    return lo, hi


def _cells(p: np.ndarray, lo: np.ndarray, hi: np.ndarray, res, dtype):
    """Cell index i0 (int), fraction t and unclamped index f per axis (see sample_field)."""
    last = np.asarray(res, dtype=dtype) - 1
    f = (p - lo) / (hi - lo) * last
    f = np.where(np.isnan(f), 0, f)  # callers turn NaN points into NaN results
    clamped = np.clip(f, 0, last)
    i0 = np.minimum(np.floor(clamped), last - 1)
    return i0.astype(np.intp), clamped - i0, f


def _mix(a: np.ndarray, b: np.ndarray, t: np.ndarray) -> np.ndarray:
    return a * (1 - t) + b * t  # GLSL mix(), in this order


def _param(params: Mapping[str, object], name: str, sizes: tuple[int, ...] = (),
           default: float | None = None, positive: bool = False):
    """params[name] as a finite float, or a tuple of floats when `sizes` lists allowed lengths."""
    value = params.get(name, default)
    if value is None:
        raise FieldError(f"field parameter {name!r} is missing; got parameters {sorted(params)}")
    try:
        array = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as e:
        raise FieldError(f"field parameter {name!r} must be numeric, got {value!r}") from e
    ok_shape = array.shape == () if not sizes else array.ndim == 1 and len(array) in sizes
    if not ok_shape or not np.isfinite(array).all() or (positive and not (array > 0).all()):
        wanted = f"a list of {' or '.join(map(str, sizes))} numbers" if sizes else "one number"
        raise FieldError(f"field parameter {name!r} must be {wanted}, finite"
                         f"{' and > 0' if positive else ''}, got {value!r}")
    return tuple(array.tolist()) if sizes else float(array)


def _stack(points, u, v, w) -> np.ndarray:
    """Components broadcast to the common shape of the points' coordinates, stacked as (..., 3)."""
    shape = np.broadcast_shapes(*(np.shape(c) for c in points))
    out = np.empty((*shape, 3))
    out[..., 0], out[..., 1], out[..., 2] = u, v, w
    return out
