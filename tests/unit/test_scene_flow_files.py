"""A scene's [field] from a NetCDF, VTK or .npz file: the file gives the grid and the box
(an .npz's box the scene's, or its own), the scene may name variables and units, a bad
file or key is one line naming it, and `[simulation] origin` moves the file's box with every
other coordinate of the scene."""

from pathlib import Path

import numpy as np
import pytest
from far_fields import (
    FORMATS,
    LOCAL_BOX,
    WORLD_BOX,
    expected_positions,
    far_scene,
    shear,
    tracers,
    world_velocity,
    write_far_field,
)
from scenes import scene_dict

from cavesim.core.errors import FieldError, SceneError
from cavesim.core.fields.flow_files import read_flow_file
from cavesim.core.fields.grid import build_series, sample_field
from cavesim.core.frame import FrameInput
from cavesim.core.scene import parse_scene
from cavesim.core.scene.model import OutOfDomain
from cavesim.core.twin.kernels import PORTABLE
from cavesim.core.twin.system import TwinSystem

FIELDS = Path(__file__).parents[2] / "config" / "fields"


def flow_scene(**field):
    data = scene_dict()
    data["field"] = {"kind": "file", **field}
    return parse_scene(data, name="flow")


def test_the_file_gives_the_grid_and_the_box():
    scene = flow_scene(file=str(FIELDS / "vortex.nc"))
    assert scene.field.resolution == (25, 25, 3)
    assert (scene.field.box_min, scene.field.box_max) == ((-6.0, -6.0, 0.0), (6.0, 6.0, 10.0))


def test_the_scene_names_units_and_variables():
    scene = flow_scene(file=str(FIELDS / "vortex.nc"), variables=["u", "v", "w"],
                       velocity_units="knots", length_units="km")
    assert scene.field.box_max == (6000.0, 6000.0, 10000.0)
    assert scene.field.variables == ("u", "v", "w")


@pytest.mark.parametrize(("field", "message"), [
    ({"file": str(FIELDS / "vortex.nc"), "box_min": [0, 0, 0]},
     r"field\.box_min .*not allowed with a \.nc file: its coordinates give the box"),
    ({"file": str(FIELDS / "vortex.vti"), "vector": "nothing"},
     r"field\.file .*vortex\.vti: PointData holds 0 arrays named 'nothing'"),
    ({"file": str(FIELDS / "vortex.vti"), "variables": ["u", "v", "w"]},
     r"field\.variables .*only allowed with a \.nc file; a \.vti file's array is `vector`"),
    ({"file": str(FIELDS / "vortex.nc"), "vector": "u"},
     r"field\.vector .*only allowed with a \.vti file"),
    ({"file": str(FIELDS / "vortex.nc"), "velocity_units": "furlongs/fortnight"},
     r"field\.file .*vortex\.nc: .*furlongs/fortnight"),
    ({"file": str(FIELDS / "make_sample_fields.py")},
     r"field\.file .*must be a \.nc \(NetCDF\) or \.vti \(VTK image\) file, or an \.npz"),
])
def test_a_bad_flow_file_or_key_is_one_line_naming_it(field, message):
    with pytest.raises(SceneError, match=message) as caught:
        flow_scene(**field)
    assert "\n" not in str(caught.value)


def test_a_vti_names_its_one_vector_array():
    scene = flow_scene(file=str(FIELDS / "vortex.vti"), vector="velocity")
    assert scene.field.named_variables == ("velocity",)
    assert scene.field.resolution == (25, 25, 3)


def test_units_and_variables_are_refused_for_an_npz(tmp_path):
    (tmp_path / "grid.npz").write_bytes(b"")  # refused for the key before it is read
    with pytest.raises(SceneError, match=r"field\.velocity_units .*only allowed with a \.nc or "
                                         r"\.vti file"):
        flow_scene(file=str(tmp_path / "grid.npz"), velocity_units="m/s",
                   box_min=[0, 0, 0], box_max=[1, 1, 1])


@pytest.mark.parametrize(("sample", "names"), [("vortex.vti", ("velocity", "x", "y")),
                                                ("vortex.nc", ("u",))])
def test_the_reader_wants_three_names_for_netcdf_and_one_for_vtk(sample, names):
    with pytest.raises(FieldError, match=rf"{sample}: variables .* names {len(names)}; "
                                         r"expected 3 for a \.nc file .* or 1 for a \.vti"):
        read_flow_file(FIELDS / sample, names)


# --- a file 5 km out, the scene's origin at its centre ---------------------------------------

FRAMES, DT = 60, np.float32(1 / 60)


@pytest.mark.parametrize("suffix", FORMATS)
def test_the_origin_moves_a_field_files_box_and_its_grid_takes_it(tmp_path, suffix):
    scene = parse_scene(far_scene(write_far_field(tmp_path, suffix)), name="far")
    assert (scene.field.box_min, scene.field.box_max) == LOCAL_BOX
    grid = build_series(scene.field).first
    assert (grid.box_min, grid.box_max) == LOCAL_BOX
    np.testing.assert_array_equal(grid.velocity, world_velocity())
    points = np.random.default_rng(1).uniform(-8.0, 8.0, (100, 3))  # from the centre
    np.testing.assert_allclose(sample_field(grid, points, OutOfDomain.ZERO),
                               shear(*points.T), rtol=0, atol=1e-12)


@pytest.mark.parametrize("out_of_domain", ["zero", "clamp"])
@pytest.mark.parametrize(("arithmetic", "atol"), [("native", 1e-9), ("portable", 1e-5)])
@pytest.mark.parametrize("suffix", FORMATS)
def test_tracers_in_a_field_file_far_out_move_with_its_flow_on_both_twins(
        tmp_path, suffix, arithmetic, atol, out_of_domain):
    """The float64 twin and the portable float32 twin carry tracers in a file's 2 m/s flow
    5 km out, its grid where the file puts it: not still (the world's box missed), nor in
    the boundary's flow."""
    data = far_scene(write_far_field(tmp_path, suffix), arithmetic=arithmetic,
                     out_of_domain=out_of_domain)
    twin = TwinSystem(parse_scene(data, name="far"))
    assert (twin.kernels is PORTABLE) is (arithmetic == "portable")
    start = tracers(32)
    twin.write_particles(start)
    for _ in range(FRAMES):
        twin.step(FrameInput(DT, np.eye(3, dtype=np.float32)))
    np.testing.assert_allclose(twin.particles.pos, expected_positions(start["pos"],
                                                                      FRAMES * float(DT)),
                               rtol=0, atol=atol)


def npz_scene(path: Path, **field):
    return parse_scene(far_scene(path, **field), name="far")


@pytest.mark.parametrize("box", [{}, {"box_min": list(WORLD_BOX[0]),
                                      "box_max": list(WORLD_BOX[1])}])
def test_an_npz_with_its_own_world_box_loads_and_is_moved(tmp_path, box):
    """Its box the file's where the scene gives none; where both give it they agree in world
    coordinates, before the origin moves them."""
    scene = npz_scene(write_far_field(tmp_path, ".npz"), **box)
    grid = build_series(scene.field).first
    assert (scene.field.box_min, scene.field.box_max) == (grid.box_min, grid.box_max) == LOCAL_BOX
    far = npz_scene(write_far_field(tmp_path, ".npz"), origin=(0.0, 0.0, 0.0), **box)
    assert (far.field.box_min, far.field.box_max) == WORLD_BOX


def test_an_npz_box_agrees_with_the_scenes_to_1e9_and_the_scenes_is_kept(tmp_path):
    path = tmp_path / "f.npz"
    np.savez(path, velocity=world_velocity(), box_min=np.array(WORLD_BOX[0]) * (1 + 1e-12),
             box_max=np.array(WORLD_BOX[1]) + 1e-12)
    scene = npz_scene(path, origin=(0.0, 0.0, 0.0), box_min=list(WORLD_BOX[0]),
                      box_max=list(WORLD_BOX[1]))
    assert (scene.field.box_min, scene.field.box_max) == WORLD_BOX


@pytest.mark.parametrize(("arrays", "field", "message"), [
    ({"box_min": np.array(WORLD_BOX[0]), "box_max": np.array(WORLD_BOX[1])},
     {"box_min": [-8.0, -8.0, -8.0], "box_max": [8.0, 8.0, 8.0]},
     r"field\.box_min = \[-8\.0, -8\.0, -8\.0\] is not allowed: must agree with .*f\.npz's "
     r"array 'box_min' = \[4992\.0, -3008\.0, 92\.0\] \(to 1e-09 relative, in world "
     r"coordinates\), or be left out: the file gives the box"),
    ({"box_min": np.array(WORLD_BOX[0])}, {"box_min": list(WORLD_BOX[0])},
     r"field\.box_max is missing: required, .* as .*f\.npz holds no array 'box_max'"),
    ({}, {}, r"field\.box_min is missing: required, .* as .*f\.npz holds no array 'box_min'"),
    ({"box_min": np.array(WORLD_BOX[0]), "box_max": np.array([5008.0, -2992.0])}, {},
     r"field\.file .*f\.npz: array 'box_max' has shape \(2,\).* expected 3 finite numbers"),
    ({"box_min": np.array(WORLD_BOX[0]), "box_max": np.array([5008.0, -2992.0, np.nan])}, {},
     r"field\.file .*f\.npz: array 'box_max' has shape \(3,\).* expected 3 finite numbers"),
    ({"box_min": np.array(WORLD_BOX[1]), "box_max": np.array(WORLD_BOX[0])}, {},
     r"field\.file .*f\.npz: the field's box corners must be 3 finite numbers each with "
     r"box_max > box_min"),
])
def test_a_bad_npz_box_is_one_line_naming_file_key_and_value(tmp_path, arrays, field, message):
    path = tmp_path / "f.npz"
    np.savez(path, velocity=world_velocity(), **arrays)
    with pytest.raises(SceneError, match=message) as caught:
        npz_scene(path, **field)
    assert "\n" not in str(caught.value)
