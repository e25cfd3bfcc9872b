"""Gridded velocity fields from NetCDF (CF conventions) and VTK XML ImageData (.vti) files.

`read_flow_file` turns one such file into a `GriddedFlow`: the velocity in m/s at the nodes of
a regular grid, x varying fastest, the box of its first and last nodes in metres, and for a
NetCDF time series its snapshot times. The caller reads cavesim's own .npz archives itself
(`cavesim.core.fields.grid`). Every bad input becomes one FieldError naming the file, the
variable or attribute and what was expected. A file is read only if it is a regular file
within MAX_FIELD_FILE_BYTES, and its sizes (nodes, snapshots) are checked against the limits
before its values are read.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from cavesim.core.errors import FieldError
from cavesim.core.fields._vtk_image import point_vectors, read_image_data
from cavesim.core.input_files import descriptor_path, open_input
from cavesim.core.limits import (
    FIELD_RESOLUTION_RANGE,
    MAX_FIELD_FILE_BYTES,
    MAX_FIELD_NODES,
    MAX_FIELD_SERIES_NODES,
    MAX_FIELD_SNAPSHOTS,
)

# The velocity components: axis, the variable name used when no standard_name matches, and
# the CF standard names (wind and sea water) that identify the component.
VELOCITY_COMPONENTS = (
    ("x", "u", ("eastward_wind", "x_wind", "eastward_sea_water_velocity",
                "sea_water_x_velocity")),
    ("y", "v", ("northward_wind", "y_wind", "northward_sea_water_velocity",
                "sea_water_y_velocity")),
    ("z", "w", ("upward_air_velocity", "upward_sea_water_velocity", "sea_water_z_velocity")),
)
# A dimension's axis from its coordinate's standard_name, else from its own name
AXIS_STANDARD_NAMES = {"projection_x_coordinate": "x", "projection_y_coordinate": "y",
                       "height": "z", "altitude": "z", "time": "t"}
AXIS_NAMES = {"x": "x", "y": "y", "z": "z", "time": "t", "t": "t"}
GEOGRAPHIC_NAMES = ("longitude", "latitude", "grid_longitude", "grid_latitude")
VELOCITY_UNITS = {"m/s": 1.0, "m s-1": 1.0, "m s**-1": 1.0, "m.s-1": 1.0, "m s^-1": 1.0,
                  "cm/s": 0.01, "cm s-1": 0.01, "km/h": 1 / 3.6, "km h-1": 1 / 3.6,
                  "knots": 0.514444, "kt": 0.514444, "kn": 0.514444}
LENGTH_UNITS = {"m": 1.0, "meter": 1.0, "meters": 1.0, "metre": 1.0, "metres": 1.0,
                "km": 1000.0, "kilometer": 1000.0, "kilometers": 1000.0,
                "kilometre": 1000.0, "kilometres": 1000.0}
# A time coordinate's units, before any " since <date>": seconds per unit
TIME_UNITS = {"s": 1.0, "sec": 1.0, "second": 1.0, "seconds": 1.0, "min": 60.0,
              "minute": 60.0, "minutes": 60.0, "h": 3600.0, "hour": 3600.0, "hours": 3600.0,
              "day": 86400.0, "days": 86400.0}
SPACING_RTOL = 1e-6  # of the spacing: how far a coordinate step may stray from uniform
FLOW_FILE_SUFFIXES = (".nc", ".vti")  # NetCDF, VTK XML ImageData (others: cavesim's .npz)
VARIABLES_NAMED = {".nc": 3, ".vti": 1}  # how many names `variables` gives for each


@dataclass(frozen=True, eq=False)
class GriddedFlow:
    """Velocity (m/s) at the nodes of a regular grid at one or more times;
    `velocity[n, k, j, i]` is the flow at box_min + (i, j, k) · (box_max − box_min) / (res − 1)
    at times[n], float32 and C-contiguous."""

    velocity: np.ndarray  # (nt, nz, ny, nx, 3), x varying fastest
    box_min: tuple[float, float, float]  # metres: the first node on each axis
    box_max: tuple[float, float, float]  # metres: the last node on each axis
    times: tuple[float, ...] = (0.0,)  # s from the first snapshot, increasing


def read_flow_file(path: Path, variables: tuple[str, ...] | None = None,
                   velocity_units: str | None = None, length_units: str | None = None,
                   time_units: str | None = None) -> GriddedFlow:
    """The flow of a .nc (NetCDF, CF conventions) or .vti (VTK XML ImageData) file.

    `variables` names the x, y and z velocity variables of a NetCDF file (else found by CF
    standard_name, else u, v, w), or the one 3-component point array of a .vti file (else
    the PointData's Vectors, else its only 3-component array).
    `velocity_units`, `length_units` and `time_units`, named by the scene, override the
    file's units attributes. VTK files have no units: their values are m/s and positions
    metres unless these say otherwise, and they hold one snapshot.
    """
    readers = dict(zip(FLOW_FILE_SUFFIXES, (_read_netcdf, _read_vti), strict=True))
    suffix = path.suffix.lower()
    if suffix not in readers:
        raise FieldError(f"{path}: unknown field file type {path.suffix!r}; expected .nc "
                         "(NetCDF, CF conventions), .vti (VTK XML ImageData) or .npz (cavesim)")
    if variables is not None and len(variables) != VARIABLES_NAMED[suffix]:
        raise FieldError(f"{path}: variables {list(variables)} names {len(variables)}; "
                         "expected 3 for a .nc file (its x, y and z velocity variables) or 1 "
                         "for a .vti file (its 3-component point array)")
    if time_units is not None and suffix != ".nc":
        raise FieldError(f"{path}: time_units names the units of a NetCDF time coordinate; a "
                         f"{suffix} file holds one snapshot")
    return readers[suffix](path, variables, velocity_units, length_units, time_units)


def _read_netcdf(path, variables, velocity_units, length_units, time_units) -> GriddedFlow:
    import xarray as xr  # here: it brings pandas, which only NetCDF files need

    with open_input(path, FieldError, "the NetCDF file", MAX_FIELD_FILE_BYTES) as file:
        try:  # netCDF4 takes a path: the one of the file held open, whatever is at `path`
            dataset = xr.open_dataset(descriptor_path(file), engine="netcdf4",
                                      decode_times=False)
        except (OSError, ValueError, RuntimeError) as e:
            raise FieldError(f"{path}: cannot read as NetCDF: {e}") from e
        with dataset:
            return _netcdf_flow(path, dataset, variables, velocity_units, length_units,
                                time_units)


def _netcdf_flow(path, dataset, variables, velocity_units, length_units,
                 time_units) -> GriddedFlow:
    """The flow of an open NetCDF dataset."""
    names = _velocity_names(path, dataset, variables)
    layouts = [_layout(path, dataset, name) for name in names]
    dims = layouts[0][0]
    if any(other != dims for other, _ in layouts):
        raise FieldError(f"{path}: variables {names} lie on different dimensions "
                         f"{[d for d, _ in layouts]}; expected the same x, y and z")
    _check_nodes(path, f"variable {names[0]!r}", [dataset.sizes[d] for d in dims])
    nodes = [_axis_nodes(path, dataset, dim, length_units) for dim in reversed(dims)]
    units = {name: dataset[name].attrs.get("units") for name in names}
    if velocity_units is None and len(set(units.values())) > 1:
        raise FieldError(f"{path}: the velocity variables have units {units}; expected the "
                         "same units on all three")
    scale = _unit_scale(path, f"variable {names[0]!r}", velocity_units or units[names[0]],
                        velocity_units is not None, VELOCITY_UNITS, "velocity_units")
    times = {time for _, time in layouts}
    if len(times) > 1:
        raise FieldError(f"{path}: variables {names} have different time dimensions "
                         f"{sorted(map(str, times))}; expected the same time, or none")
    time = times.pop()
    snapshots = dataset.sizes[time] if time else 1
    if snapshots > MAX_FIELD_SNAPSHOTS:
        raise FieldError(f"{path}: time dimension {time!r} holds {snapshots:,} snapshots; "
                         f"at most MAX_FIELD_SNAPSHOTS = {MAX_FIELD_SNAPSHOTS} are allowed "
                         "(a series' snapshots are stacked in one 3D texture)")
    grid_nodes = math.prod(dataset.sizes[d] for d in dims)
    if grid_nodes * snapshots > MAX_FIELD_SERIES_NODES:
        raise FieldError(f"{path}: {snapshots} snapshots of {grid_nodes} nodes; expected at "
                         f"most {MAX_FIELD_SERIES_NODES} nodes in all snapshots together")
    components = [_finite_float32(path, f"variable {name!r}",
                                  _values(path, dataset, name, dims, time) * scale)
                  for name in names]
    seconds = (0.0,) if snapshots == 1 else _snapshot_times(path, dataset, time, time_units)
    box_min, box_max = zip(*nodes, strict=True)
    return GriddedFlow(np.stack(components, axis=-1), box_min, box_max, seconds)


def _velocity_names(path, dataset, variables) -> tuple[str, ...]:
    """The x, y, z velocity variables: as named, else by CF standard_name, else u, v, w."""
    data_vars = list(dataset.data_vars)
    names = []
    for i, (axis, fallback, standard_names) in enumerate(VELOCITY_COMPONENTS):
        if variables is not None:
            name, how = variables[i], f"named {variables[i]!r}"
        else:
            matches = [n for n in data_vars
                       if dataset[n].attrs.get("standard_name") in standard_names]
            if len(matches) > 1:
                raise FieldError(f"{path}: variables {matches} all have an {axis} velocity "
                                 "standard_name; expected one, or the scene naming the variables")
            name = matches[0] if matches else fallback
            how = f"with a standard_name in {standard_names} or named {fallback!r}"
        if name not in dataset.data_vars:
            raise FieldError(f"{path}: no {axis} velocity variable {how}; the file's data "
                             f"variables are {data_vars}")
        names.append(name)
    return tuple(names)


def _layout(path, dataset, name) -> tuple[tuple[str, str, str], str | None]:
    """The variable's (z, y, x) dimensions and its time dimension (None if it has none)."""
    dims = dataset[name].dims
    axes: dict[str, str] = {}
    for dim in dims:
        axis = _axis_of(path, dataset, name, dim)
        if axis in axes:
            raise FieldError(f"{path}: variable {name!r} has dimensions {dims}, two of them "
                             f"({axes[axis]!r}, {dim!r}) on the {axis} axis; expected one each")
        axes[axis] = dim
    if {"x", "y", "z"} - set(axes):
        raise FieldError(f"{path}: variable {name!r} has dimensions {dims}; expected x, y and z "
                         "(and at most a time)")
    return (axes["z"], axes["y"], axes["x"]), axes.get("t")


def _axis_of(path, dataset, name, dim) -> str:
    """'x', 'y', 'z' or 't': the coordinate's axis attribute, else standard_name, else name."""
    attrs = dataset[dim].attrs if dim in dataset.variables else {}
    standard_name = attrs.get("standard_name")
    if standard_name in GEOGRAPHIC_NAMES or str(attrs.get("units", "")).startswith("degree"):
        raise FieldError(f"{path}: dimension {dim!r} of variable {name!r} is geographic "
                         f"({standard_name or attrs['units']}); geographic coordinates must be "
                         "projected to metres (projection_x_coordinate, projection_y_coordinate)")
    axis = str(attrs.get("axis", "")).lower()
    if axis not in ("x", "y", "z", "t"):
        axis = AXIS_STANDARD_NAMES.get(standard_name) or AXIS_NAMES.get(dim)
    if axis is None:
        raise FieldError(f"{path}: dimension {dim!r} of variable {name!r} has no axis; expected "
                         "an axis attribute X, Y, Z or T on its coordinate variable, a "
                         f"standard_name in {list(AXIS_STANDARD_NAMES)} or a name x, y, z, time")
    if axis == "z" and attrs.get("positive") == "down":
        raise FieldError(f"{path}: coordinate {dim!r} has positive = 'down'; expected z upward")
    return axis


def _coordinate(path, dataset, dim, what: str, holding: str) -> np.ndarray:
    """The 1-D, finite, numeric coordinate variable of dimension `dim`."""
    if dim not in dataset.coords:
        raise FieldError(f"{path}: dimension {dim!r} has no coordinate variable; expected a "
                         f"1-D variable {dim!r} of {holding}")
    values = np.asarray(dataset[dim].values)
    if values.ndim != 1 or values.dtype.kind not in "iuf" or not np.isfinite(values).all():
        raise FieldError(f"{path}: {what} {dim!r} has shape {values.shape}, dtype "
                         f"{values.dtype}; expected 1-D finite numbers")
    return values


def _axis_nodes(path, dataset, dim, length_units) -> tuple[float, float]:
    """The first and last node of a uniform, strictly increasing coordinate, in metres."""
    values = _coordinate(path, dataset, dim, "coordinate", "node positions")
    steps = np.diff(values.astype(np.float64))
    spacing = (float(values[-1]) - float(values[0])) / len(steps)
    if not (steps > 0).all() or np.abs(steps - spacing).max() > SPACING_RTOL * spacing:
        raise FieldError(f"{path}: coordinate {dim!r} has steps from {steps.min()} to "
                         f"{steps.max()}; expected strictly increasing, uniformly spaced nodes "
                         f"(to {SPACING_RTOL} of the spacing)")
    scale = _unit_scale(path, f"coordinate {dim!r}", length_units or dataset[dim].attrs.get(
        "units"), length_units is not None, LENGTH_UNITS, "length_units")
    return float(values[0]) * scale, float(values[-1]) * scale


def _snapshot_times(path, dataset, dim, time_units) -> tuple[float, ...]:
    """The time coordinate in seconds from its first value: strictly increasing and finite,
    in units such as "seconds since 2026-01-01" (or the scene's time_units)."""
    values = _coordinate(path, dataset, dim, "time coordinate", "snapshot times")
    unit = time_units or dataset[dim].attrs.get("units")
    named = time_units is not None
    word = None if unit is None else str(unit).split(" since ")[0]
    scale = _unit_scale(path, f"time coordinate {dim!r}", word, named, TIME_UNITS, "time_units")
    seconds = (values.astype(np.float64) - float(values[0])) * scale
    if len(seconds) > 1 and not (np.diff(seconds) > 0).all():
        raise FieldError(f"{path}: time coordinate {dim!r} is {values.tolist()[:6]}...; "
                         "expected strictly increasing snapshot times")
    return tuple(seconds.tolist())


def _values(path, dataset, name, dims, time) -> np.ndarray:
    """The variable as float64 (t, z, y, x), t of length 1 when it has no time; fill
    values become NaN."""
    variable = dataset[name] if time else dataset[name].expand_dims("_snapshot")
    try:
        values = variable.transpose(time or "_snapshot", *dims).values
    except (OSError, ValueError, RuntimeError) as e:
        raise FieldError(f"{path}: cannot read variable {name!r}: {e}") from e
    if values.dtype.kind not in "iuf":
        raise FieldError(f"{path}: variable {name!r} has dtype {values.dtype}; expected numbers")
    return values.astype(np.float64)


def _read_vti(path, variables, velocity_units, length_units, _time_units) -> GriddedFlow:
    image = read_image_data(path)
    _check_nodes(path, "ImageData WholeExtent", image.shape)
    where, values = point_vectors(path, image, variables[0] if variables else None)
    scale = _unit_scale(path, where, velocity_units or "m/s", velocity_units is not None,
                        VELOCITY_UNITS, "velocity_units")
    length = _unit_scale(path, "ImageData", length_units or "m", length_units is not None,
                         LENGTH_UNITS, "length_units")
    velocity = _finite_float32(path, where, values[np.newaxis] * scale)
    box_min, box_max = (tuple(length * v for v in corner) for corner in image.corners)
    return GriddedFlow(velocity, box_min, box_max)


def _check_nodes(path, what, shape) -> None:
    """FieldError unless (nz, ny, nx) lies in FIELD_RESOLUTION_RANGE and MAX_FIELD_NODES."""
    low, high = FIELD_RESOLUTION_RANGE
    if not all(low <= n <= high for n in shape) or math.prod(shape) > MAX_FIELD_NODES:
        raise FieldError(f"{path}: {what} has {tuple(shape)} (z, y, x) nodes; expected {low} to "
                         f"{high} per axis and at most {MAX_FIELD_NODES} in all")


def _unit_scale(path, what, unit, named, table, argument) -> float:
    """The factor from `unit` to SI; `named`: the scene named it, as `argument`."""
    if unit is None:
        raise FieldError(f"{path}: {what} has no 'units' attribute; expected one of "
                         f"{list(table)}, or the scene naming it ({argument})")
    if str(unit).strip() not in table:
        origin = f"the scene's {argument}" if named else "its 'units' attribute"
        raise FieldError(f"{path}: {what} has units {unit!r} ({origin}); expected one of "
                         f"{list(table)}")
    return table[str(unit).strip()]


def _finite_float32(path, what, values) -> np.ndarray:
    """`values` (nodes (t, z, y, x) first) as C-contiguous float32; FieldError on a missing,
    non-finite or float32-overflowing node."""
    with np.errstate(over="ignore", invalid="ignore"):
        grid = np.ascontiguousarray(values, dtype=np.float32)
    bad = ~np.isfinite(grid).reshape(*grid.shape[:4], -1).all(axis=-1)
    if bad.any():
        first = tuple(int(i) for i in np.argwhere(bad)[0])
        axes = "(t, z, y, x)" if len(grid) > 1 else "(z, y, x)"
        first = first if len(grid) > 1 else first[1:]
        raise FieldError(f"{path}: {what} has {int(bad.sum())} node(s) missing (_FillValue) or "
                         f"not finite (NaN, inf or beyond float32), the first at {axes} "
                         f"{first}; expected a finite value at every node")
    return grid
