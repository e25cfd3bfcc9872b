"""Flow fields from NetCDF (CF) and VTK ImageData files: the samples, layouts, units, refusals."""

from __future__ import annotations

import base64
import math
import re
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from cavesim.core.errors import FieldError
from cavesim.core.fields.flow_files import read_flow_file

SAMPLES = Path(__file__).resolve().parents[2] / "config" / "fields"
X, Y, Z = np.arange(4.0), np.array([0.0, 2.0, 4.0]), np.array([10.0, 11.0])
BOX_MIN, BOX_MAX = (0.0, 0.0, 10.0), (3.0, 4.0, 11.0)


def linear_velocity() -> np.ndarray:
    """(nz, ny, nx, 3) with u = x + 10 y + 100 z, v = -u, w = 2 u: every node tells its place."""
    u = X[None, None, :] + 10 * Y[None, :, None] + 100 * Z[:, None, None]
    return np.stack([u, -u, 2 * u], axis=-1).astype(np.float32)


def linear_dataset() -> xr.Dataset:
    velocity = linear_velocity()
    data = {name: (("z", "y", "x"), velocity[..., i], {"units": "m/s"})
            for i, name in enumerate("uvw")}
    coords = {name: (name, values, {"units": "m"})
              for name, values in zip("xyz", (X, Y, Z), strict=True)}
    return xr.Dataset(data, coords=coords)


def write_nc(tmp_path: Path, dataset: xr.Dataset) -> Path:
    path = tmp_path / "flow.nc"
    dataset.to_netcdf(path, engine="netcdf4")
    return path


def raises(path: Path, what: str):
    """FieldError whose message names the file and then `what` (a regular expression)."""
    return pytest.raises(FieldError, match=re.escape(str(path)) + ".*" + what)


@pytest.mark.parametrize("name", ["vortex.nc", "vortex.vti"])
def test_samples_hold_the_lamb_oseen_vortex(name):
    x, y, z = np.linspace(-6, 6, 25), np.linspace(-6, 6, 25), np.linspace(0, 10, 3)
    zz, yy, xx = np.meshgrid(z, y, x, indexing="ij")
    r2 = xx**2 + yy**2
    # v_θ = Γ / (2π r) (1 − exp(−r²/rc²)), Γ = 20 m²/s, rc = 1 m; its r → 0 limit is 0
    per_r2 = np.divide(1 - np.exp(-r2), r2, out=np.ones_like(r2), where=r2 > 0)
    scale = 20 / (2 * math.pi) * per_r2
    expected = np.stack([-scale * yy, scale * xx, np.full_like(xx, 0.5)], axis=-1)
    flow = read_flow_file(SAMPLES / name)
    assert flow.velocity[0].dtype == np.float32 and flow.velocity[0].flags["C_CONTIGUOUS"]
    np.testing.assert_allclose(flow.velocity[0], expected.astype(np.float32), rtol=1e-6, atol=1e-6)
    assert flow.box_min == (-6.0, -6.0, 0.0) and flow.box_max == (6.0, 6.0, 10.0)


def test_netcdf_dims_in_any_order_read_the_same(tmp_path):
    flow = read_flow_file(write_nc(tmp_path, linear_dataset().transpose("x", "z", "y")))
    np.testing.assert_array_equal(flow.velocity[0], linear_velocity())
    assert flow.velocity[0].flags["C_CONTIGUOUS"]
    assert (flow.box_min, flow.box_max) == (BOX_MIN, BOX_MAX)


def test_netcdf_km_and_cm_per_s_are_converted(tmp_path):
    dataset = linear_dataset()
    dataset = dataset.assign_coords({n: (n, dataset[n].values / 1000, {"units": "km"})
                                     for n in "xyz"})
    for name in "uvw":
        dataset[name] = dataset[name] * 100
        dataset[name].attrs["units"] = "cm s-1"
    flow = read_flow_file(write_nc(tmp_path, dataset))
    np.testing.assert_allclose(flow.velocity[0], linear_velocity(), rtol=1e-6)
    np.testing.assert_allclose([flow.box_min, flow.box_max], [BOX_MIN, BOX_MAX], rtol=1e-12)


def test_netcdf_variables_by_standard_name_and_by_name(tmp_path):
    standard_names = ("eastward_sea_water_velocity", "northward_sea_water_velocity",
                      "upward_sea_water_velocity")
    dataset = linear_dataset().rename({"u": "ue", "v": "vn", "w": "wu"})
    for name, standard_name in zip(("ue", "vn", "wu"), standard_names, strict=True):
        dataset[name].attrs["standard_name"] = standard_name
    path = write_nc(tmp_path, dataset)
    np.testing.assert_array_equal(read_flow_file(path).velocity[0], linear_velocity())
    swapped = read_flow_file(path, variables=("vn", "ue", "wu")).velocity[0]
    np.testing.assert_array_equal(swapped, linear_velocity()[..., [1, 0, 2]])


def test_netcdf_time_of_length_one_is_one_snapshot(tmp_path):
    one = linear_dataset().expand_dims(time=[0.0])
    flow = read_flow_file(write_nc(tmp_path, one))
    assert flow.velocity.shape == (1, 2, 3, 4, 3) and flow.times == (0.0,)


def longitude(dataset: xr.Dataset) -> xr.Dataset:
    dataset = dataset.rename({"x": "lon"})
    dataset["lon"].attrs.update(standard_name="longitude", units="degrees_east", axis="X")
    return dataset


def without_velocity_units(dataset: xr.Dataset) -> xr.Dataset:
    for name in "uvw":
        del dataset[name].attrs["units"]
    return dataset


def with_nan(dataset: xr.Dataset) -> xr.Dataset:
    dataset["v"][1, 2, 3] = np.nan
    return dataset


@pytest.mark.parametrize("change, what", [
    (lambda d: d.assign_coords(x=("x", [0.0, 1.0, 2.0, 4.0], {"units": "m"})),
     r"coordinate 'x' has steps from 1.0 to 2.0; expected .*uniformly spaced"),
    (longitude, r"'lon' of variable 'u' is geographic.*must be projected"),
    (without_velocity_units, r"variable 'u' has no 'units' attribute.*the scene naming it"),
    (with_nan, r"variable 'v' has 1 node\(s\) missing .* at \(z, y, x\) \(1, 2, 3\)"),
    (lambda d: d.drop_vars("w"), r"no z velocity variable.* data variables are \['u', 'v'\]"),
])
def test_netcdf_refusals_name_the_file_and_the_fault(tmp_path, change, what):
    path = write_nc(tmp_path, change(linear_dataset()))
    with raises(path, what):
        read_flow_file(path)


def test_netcdf_units_named_by_the_scene_stand_in_for_the_file(tmp_path):
    path = write_nc(tmp_path, without_velocity_units(linear_dataset()))
    flow = read_flow_file(path, velocity_units="km/h")
    np.testing.assert_allclose(flow.velocity[0], linear_velocity() / 3.6, rtol=1e-6)


def test_a_file_that_is_not_netcdf_is_refused(tmp_path):
    path = tmp_path / "flow.nc"
    path.write_text("u, v, w\n1, 2, 3\n")
    with raises(path, "cannot read as NetCDF"):
        read_flow_file(path)


# --- VTK XML ImageData ------------------------------------------------------------------
# WholeExtent "1 4 3 5 0 1" (4 x 3 x 2 nodes) from Origin (10, 20, 30), Spacing (0.5, 1, 2)
VTI_BOX = ((10.5, 23.0, 30.0), (12.0, 25.0, 32.0))


def write_vti(tmp_path: Path, storage="binary", header="UInt32", order="LittleEndian",
              root="", image="", section="PointData") -> Path:
    values = linear_velocity()
    if storage == "ascii":
        text = " ".join(repr(v) for v in values.ravel().tolist())
    else:
        endian = "<" if order == "LittleEndian" else ">"
        data = values.astype(endian + "f4").tobytes()
        size = np.array(len(data), endian + {"UInt32": "u4", "UInt64": "u8"}[header])
        text = base64.b64encode(size.tobytes() + data).decode()
    path = tmp_path / "flow.vti"
    path.write_text(
        f'<VTKFile type="ImageData" byte_order="{order}" header_type="{header}" {root}>'
        f'<ImageData WholeExtent="1 4 3 5 0 1" Origin="10 20 30" Spacing="0.5 1 2" {image}>'
        f'<Piece Extent="1 4 3 5 0 1"><{section}><DataArray type="Float32" Name="velocity" '
        f'NumberOfComponents="3" format="{storage}">{text}</DataArray></{section}></Piece>'
        '</ImageData></VTKFile>')
    return path


@pytest.mark.parametrize("storage, header, order", [
    ("ascii", "UInt32", "LittleEndian"), ("binary", "UInt32", "LittleEndian"),
    ("binary", "UInt64", "LittleEndian"), ("binary", "UInt32", "BigEndian"),
])
def test_vti_ascii_and_binary_read_the_same(tmp_path, storage, header, order):
    flow = read_flow_file(write_vti(tmp_path, storage, header, order))
    np.testing.assert_array_equal(flow.velocity[0], linear_velocity())
    assert (flow.box_min, flow.box_max) == VTI_BOX


def test_vti_units_named_by_the_scene_scale_positions_and_values(tmp_path):
    flow = read_flow_file(write_vti(tmp_path), velocity_units="knots", length_units="km")
    np.testing.assert_allclose(flow.velocity[0], linear_velocity() * 0.514444, rtol=1e-6)
    np.testing.assert_allclose([flow.box_min, flow.box_max], np.array(VTI_BOX) * 1000)


@pytest.mark.parametrize("kw, what", [
    ({"storage": "appended"}, r"format 'appended'; expected ascii or binary.*Compressor None"),
    ({"root": 'compressor="vtkZLibDataCompressor"'}, r"compressed.*Compressor None"),
    ({"image": 'Direction="0 1 0 1 0 0 0 0 1"'}, r"Direction is '0 1 0 1 0 0 0 0 1'; expected "
                                                  r"the identity"),
    ({"section": "CellData"}, r"no PointData arrays \(CellData arrays: 1\)"),
])
def test_vti_refusals_name_the_file_and_the_fault(tmp_path, kw, what):
    path = write_vti(tmp_path, **kw)
    with raises(path, what):
        read_flow_file(path)


def test_an_unknown_suffix_is_refused(tmp_path):
    path = tmp_path / "flow.h5"
    with raises(path, r"unknown field file type '\.h5'; expected \.nc .*\.vti .*\.npz"):
        read_flow_file(path)
