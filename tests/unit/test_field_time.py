"""Fields as time series: where each stage of a step stands between snapshots, how that
travels in the frame message, and the files and scenes that make a series."""

from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from scenes import scene_dict

from cavesim.core.drivers import FieldClock, StillDriver, driver_for
from cavesim.core.errors import FieldError, ProtocolError, SceneError
from cavesim.core.features.grid_flow import series_flow
from cavesim.core.fields.analytic import rotating_velocity
from cavesim.core.fields.grid import build_field, build_series, sample_field
from cavesim.core.fields.snapshot_time import FIELD_TIME_PARAMS, FieldTime, field_time_at
from cavesim.core.scene import parse_scene
from cavesim.core.scene.model import OutOfDomain
from cavesim.core.twin.kernels import PORTABLE, reference_kernels

FIELDS = Path(__file__).parents[2] / "config" / "fields"
TIMES = (0.0, 0.5, 1.0, 2.0)


def rotating_scene(**params) -> object:
    data = scene_dict()
    data["field"] = {"kind": "rotating", "box_min": [-5.0, -5.0, -5.0],
                     "box_max": [5.0, 5.0, 5.0], "resolution": [2, 2, 2],
                     "params": {"velocity": [2.0, 0.0, 0.5], "angular_speed": 1.5,
                                "snapshot_interval": 0.25, "snapshots": 9, **params}}
    return parse_scene(data, name="rotating")


def test_each_stage_gets_the_pair_its_time_lies_in_and_the_weight_there():
    inside = field_time_at(TIMES, 0.25, 0.5)  # stages at 0.25, 0.5, 0.75 s
    assert inside.pairs == (0, 1, 1)  # 0.5 s is the start of the second pair
    assert inside.weights == (0.5, 0.0, 0.5)
    uneven = field_time_at(TIMES, 1.0, 0.5)  # the last pair is 1 s long
    assert uneven.pairs == (2, 2, 2) and uneven.weights == (0.0, 0.25, 0.5)


def test_before_the_first_and_after_the_last_snapshot_they_hold():
    assert field_time_at(TIMES, -1.0, 0.5) == FieldTime((0, 0, 0), (0.0, 0.0, 0.0))
    assert field_time_at(TIMES, 5.0, 0.5) == FieldTime((2, 2, 2), (1.0, 1.0, 1.0))


def test_weights_travel_as_float32_and_decode_to_the_same_bits():
    field_time = field_time_at(TIMES, 0.1, 1 / 60)
    assert all(np.float32(w) == w for w in field_time.weights)
    assert FieldTime.decode(field_time.encode(), len(TIMES)) == field_time


@pytest.mark.parametrize("params, what", [
    ((0, 1, 3, 0.0, 0.0, 0.0), "pairs .* from 0 to 2"),
    ((0, 0.5, 1, 0.0, 0.0, 0.0), "pairs .* whole numbers"),
    ((0, 1, 2, 0.0, float("nan"), 0.0), "weights .* from 0 to 1"),
    ((0, 1, 2, 0.0, 1.5, 0.0), "weights .* from 0 to 1"),
])
def test_a_frame_with_field_time_out_of_range_is_a_protocol_error(params, what):
    with pytest.raises(ProtocolError, match=what):
        FieldTime.decode(params, len(TIMES))


def test_the_clock_appends_field_time_to_the_scene_drivers_parameters():
    scene = rotating_scene()
    driver = driver_for(scene)
    assert isinstance(driver, FieldClock) and isinstance(driver.scene_driver, StillDriver)
    step = driver.advance(0.3, 1 / 60, None)
    params = driver.encode(step.frame)
    assert len(params) == len(StillDriver().encode(step.frame)) + FIELD_TIME_PARAMS
    frame = driver.decode(params)
    assert frame.field_time == step.frame.field_time == field_time_at(scene.field.times,
                                                                      0.3, 1 / 60)
    assert frame.helicopter == StillDriver().decode(StillDriver().encode(step.frame)).helicopter
    with pytest.raises(ProtocolError, match="ends in 6 field time parameters, got 5"):
        driver.decode(params[:5])
    assert not isinstance(driver_for(parse_scene(scene_dict(), name="steady")), FieldClock)


def test_a_rotating_field_is_its_closed_form_at_every_snapshot():
    scene = rotating_scene()
    assert scene.field.times == tuple(0.25 * k for k in range(9))
    series = build_series(scene.field)
    for t, grid in zip(scene.field.times, series.snapshots, strict=True):
        np.testing.assert_allclose(grid.velocity[1, 0, 1],
                                   rotating_velocity(t, scene.field.params), rtol=1e-7)
    assert series.texture_size == (2, 2, 18)
    assert series.texels().shape == (18, 2, 2, 3)
    with pytest.raises(FieldError, match="time series of 9 snapshots; its grids come from "
                                         "build_series"):
        build_field(scene.field)


@pytest.mark.parametrize("kernels", [reference_kernels(np.float64), PORTABLE],
                         ids=["float64", "portable"])
def test_the_twins_mix_each_stages_pair_linearly_in_time(kernels):
    scene = rotating_scene()
    series = build_series(scene.field)
    p = np.zeros((1, 3), dtype=kernels.dtype)
    field_time = field_time_at(scene.field.times, 0.3, 0.1)  # 0.3, 0.35 and 0.4 s
    for stage, t in enumerate((0.3, 0.35, 0.4)):
        pair = field_time.pairs[stage]
        t0, t1 = scene.field.times[pair], scene.field.times[pair + 1]
        a, b = (sample_field(series.snapshots[k], p, OutOfDomain.CLAMP) for k in (pair, pair + 1))
        expected = a + (t - t0) / (t1 - t0) * (b - a)
        u = series_flow(series, p, OutOfDomain.CLAMP, field_time, stage, kernels)
        np.testing.assert_allclose(u, expected, rtol=2e-6, atol=1e-6)
    with pytest.raises(ValueError, match="start, middle and end"):
        series_flow(series, p, OutOfDomain.CLAMP, field_time, None, kernels)


def series_dataset(times, units="seconds since 2026-01-01") -> xr.Dataset:
    velocity = np.arange(len(times) * 2 * 2 * 2, dtype=np.float32).reshape(len(times), 2, 2, 2)
    coords = {"x": ("x", [0.0, 1.0], {"units": "m"}), "y": ("y", [0.0, 1.0], {"units": "m"}),
              "z": ("z", [0.0, 1.0], {"units": "m"}),
              "time": ("time", np.array(times), {"units": units} if units else {})}
    return xr.Dataset({name: (("time", "z", "y", "x"), velocity + i, {"units": "m/s"})
                       for i, name in enumerate("uvw")}, coords=coords)


def test_a_netcdf_time_series_is_read_with_its_times_in_seconds(tmp_path):
    path = tmp_path / "series.nc"
    series_dataset([10.0, 10.5, 12.0], "minutes since 2026-01-01").to_netcdf(path)
    data = scene_dict()
    data["field"] = {"kind": "file", "file": str(path)}
    scene = parse_scene(data, name="series")
    assert scene.field.times == (0.0, 30.0, 120.0)
    series = build_series(scene.field)
    assert len(series.snapshots) == 3
    np.testing.assert_array_equal(series.snapshots[2].velocity[..., 1],
                                  np.arange(16, 24, dtype=np.float32).reshape(2, 2, 2) + 1)
    data["field"]["time_units"] = "hours"
    assert parse_scene(data, name="series").field.times == (0.0, 1800.0, 7200.0)


@pytest.mark.parametrize("times, units, what", [
    ([0.0, 2.0, 1.0], "s", "time coordinate 'time' is .*expected strictly increasing"),
    ([0.0, 1.0], None, "time coordinate 'time' has no 'units' attribute"),
    ([0.0, 1.0], "fortnights since 2026-01-01",
     r"has units 'fortnights' \(its 'units' attribute\); expected one of"),
])
def test_a_bad_time_coordinate_is_one_line_naming_it(tmp_path, times, units, what):
    path = tmp_path / "series.nc"
    series_dataset(times, units).to_netcdf(path)
    data = scene_dict()
    data["field"] = {"kind": "file", "file": str(path)}
    with pytest.raises(SceneError, match=f"field.file = .*series.nc.*{what}"):
        parse_scene(data, name="series")


def test_an_npz_time_series_has_times_beside_its_velocity(tmp_path):
    path = tmp_path / "series.npz"
    velocity = np.zeros((3, 2, 2, 2, 3), dtype=np.float32)
    velocity[:, ..., 0] = np.array([1.0, 2.0, 4.0])[:, None, None, None]
    np.savez(path, velocity=velocity, times=np.array([5.0, 6.0, 8.0]))
    data = scene_dict()
    data["field"] = {"kind": "file", "file": str(path), "box_min": [0.0, 0.0, 0.0],
                     "box_max": [1.0, 1.0, 1.0]}
    scene = parse_scene(data, name="series")
    assert scene.field.times == (0.0, 1.0, 3.0) and scene.field.resolution == (2, 2, 2)
    assert [g.velocity[0, 0, 0, 0] for g in build_series(scene.field).snapshots] == [1, 2, 4]
    np.savez(path, velocity=velocity, times=np.array([5.0, 5.0, 8.0]))
    with pytest.raises(SceneError, match="array 'times' .*strictly increasing"):
        parse_scene(data, name="series")


@pytest.mark.parametrize("field, what", [
    ({"kind": "rotating", "times": [0.0, 1.0]}, "field.times .*not a key"),
    ({"kind": "file", "file": str(FIELDS / "vortex.vti"), "time_units": "s"},
     "field.time_units .*only allowed with a .nc file"),
])
def test_times_come_from_the_file_or_the_kind_not_from_the_scene(field, what):
    data = scene_dict()
    data["field"] = field
    with pytest.raises(SceneError, match=what):
        parse_scene(data, name="times")
