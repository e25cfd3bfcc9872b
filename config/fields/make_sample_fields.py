"""Write the sample flow files vortex.nc (NetCDF, CF-1.8), vortex.vti (VTK XML ImageData)
and the time series pulsing_vortex.nc (NetCDF, CF-1.8).

The first two hold the same Lamb–Oseen vortex (cavesim.core.fields.analytic.vortex_velocity):
circulation 20 m²/s, core radius 1 m, axis through (0, 0), axial flow 0.5 m/s upward, on
25 × 25 × 3 nodes over x, y in [-6, 6] m and z in [0, 10] m. pulsing_vortex.nc holds that
vortex at 9 times, every 0.5 s, its circulation 20 (1 + 0.5 sin(2π t / 4 s)) m²/s.
Run from the repository root:
    python config/fields/make_sample_fields.py
"""

from __future__ import annotations

import base64
from pathlib import Path

import numpy as np
import xarray as xr

from cavesim.core.fields.analytic import vortex_velocity

HERE = Path(__file__).resolve().parent
VORTEX = {"center": (0.0, 0.0), "circulation": 20.0, "core_radius": 1.0, "axial_speed": 0.5}
BOX_MIN, BOX_MAX = (-6.0, -6.0, 0.0), (6.0, 6.0, 10.0)
RESOLUTION = (25, 25, 3)  # nodes along x, y, z


PULSE_TIMES = tuple(0.5 * k for k in range(9))  # s
PULSE_PERIOD = 4.0  # s


def vortex_nodes(circulation: float = VORTEX["circulation"]
                 ) -> tuple[tuple[np.ndarray, ...], np.ndarray]:
    """The node coordinates (x, y, z) and the float32 velocity (nz, ny, nx, 3) there."""
    x, y, z = (np.linspace(a, b, n) for a, b, n in zip(BOX_MIN, BOX_MAX, RESOLUTION, strict=True))
    velocity = vortex_velocity(x[None, None, :], y[None, :, None], z[:, None, None],
                               {**VORTEX, "circulation": circulation})
    return (x, y, z), velocity.astype(np.float32)


def write_netcdf(path: Path, times: tuple[float, ...] | None = None) -> None:
    """CF-1.8 NetCDF: coordinates x, y, z and variables u, v, w on dimensions (z, y, x);
    with `times`, the pulsing vortex at each, on dimensions (time, z, y, x)."""
    (x, y, z), velocity = vortex_nodes()
    coordinates = {
        "x": ("x", x, {"axis": "X", "units": "m", "standard_name": "projection_x_coordinate"}),
        "y": ("y", y, {"axis": "Y", "units": "m", "standard_name": "projection_y_coordinate"}),
        "z": ("z", z, {"axis": "Z", "units": "m", "standard_name": "height",
                       "positive": "up"}),
    }
    dims = ("z", "y", "x")
    if times is not None:
        velocity = np.stack([vortex_nodes(pulsing_circulation(t))[1] for t in times])
        coordinates["time"] = ("time", np.array(times), {
            "axis": "T", "standard_name": "time", "units": "seconds since 2026-01-01 00:00:00"})
        dims = ("time", *dims)
    names = {"u": "eastward_wind", "v": "northward_wind", "w": "upward_air_velocity"}
    variables = {name: (dims, velocity[..., i], {"units": "m s-1",
                                                 "standard_name": standard_name})
                 for i, (name, standard_name) in enumerate(names.items())}
    dataset = xr.Dataset(variables, coords=coordinates, attrs={
        "Conventions": "CF-1.8", "title": "Lamb-Oseen vortex, cavesim sample field",
        "source": "config/fields/make_sample_fields.py"})
    encoding = {name: {"_FillValue": None} for name in (*coordinates, *names)}
    dataset.to_netcdf(path, engine="netcdf4", encoding=encoding)


def pulsing_circulation(t: float) -> float:
    """m²/s at t: the sample vortex's, swelling and easing by half over PULSE_PERIOD."""
    return VORTEX["circulation"] * (1.0 + 0.5 * np.sin(2.0 * np.pi * t / PULSE_PERIOD))


def write_vti(path: Path) -> None:
    """VTK XML ImageData with a "velocity" point array: Float32, base64 with a UInt32 header."""
    _, velocity = vortex_nodes()
    nx, ny, nz = RESOLUTION
    spacing = [(b - a) / (n - 1) for a, b, n in zip(BOX_MIN, BOX_MAX, RESOLUTION, strict=True)]
    data = velocity.astype("<f4").tobytes()
    encoded = base64.b64encode(np.array(len(data), "<u4").tobytes() + data).decode()
    extent = f"0 {nx - 1} 0 {ny - 1} 0 {nz - 1}"
    path.write_text(
        '<?xml version="1.0"?>\n'
        '<VTKFile type="ImageData" version="1.0" byte_order="LittleEndian" '
        'header_type="UInt32">\n'
        f'  <ImageData WholeExtent="{extent}" Origin="{" ".join(map(str, BOX_MIN))}" '
        f'Spacing="{" ".join(map(str, spacing))}" Direction="1 0 0 0 1 0 0 0 1">\n'
        f'    <Piece Extent="{extent}">\n'
        '      <PointData Vectors="velocity">\n'
        '        <DataArray type="Float32" Name="velocity" NumberOfComponents="3" '
        f'format="binary">\n          {encoded}\n        </DataArray>\n'
        '      </PointData>\n'
        '    </Piece>\n'
        '  </ImageData>\n'
        '</VTKFile>\n')


def main() -> None:
    write_netcdf(HERE / "vortex.nc")
    write_vti(HERE / "vortex.vti")
    write_netcdf(HERE / "pulsing_vortex.nc", PULSE_TIMES)


if __name__ == "__main__":
    main()
