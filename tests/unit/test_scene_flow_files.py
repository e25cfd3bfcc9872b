"""A scene's [field] from a NetCDF or VTK file: the file gives the grid and the box, the
scene may name variables and units, and a bad file or key is one line naming it."""

from pathlib import Path

import pytest
from scenes import scene_dict

from cavesim.core.errors import FieldError, SceneError
from cavesim.core.fields.flow_files import read_flow_file
from cavesim.core.scene import parse_scene

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
