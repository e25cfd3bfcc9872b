"""Vector field and height field grids on the CPU: building, sampling and the .npz edge (no GL)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from cavesim.core.errors import FieldError
from cavesim.core.fields.analytic import downwash_velocity, vortex_velocity
from cavesim.core.fields.grid import FieldGrid, build_field, sample_field, save_field
from cavesim.core.fields.heights import (
    HeightGrid,
    load_heightfield,
    sample_height,
    save_heightfield,
)
from cavesim.core.scene.model import Field, FieldKind, OutOfDomain

BOX_MIN, BOX_MAX = (-2.0, -1.5, 0.0), (3.0, 2.5, 2.0)
VORTEX = {"center": (0.5, 0.25), "circulation": 2.0, "core_radius": 0.4, "axial_speed": 0.1}
DOWNWASH = {"rotor_center": (0.0, 0.0, 3.0), "rotor_radius": 1.0, "induced_velocity": 5.0,
            "ground_height": 0.0}
# v = LINEAR @ p + OFFSET: dyadic numbers, so on the dyadic nodes of linear_grid() the float32
# node values are exact and trilinear sampling must reproduce v to float64 rounding
LINEAR = np.array([[0.25, -1.25, 0.5], [2.0, 0.125, -0.75], [-0.5, 1.0, 1.125]])
OFFSET = np.array([0.25, -0.5, 1.0])


def make_field(kind: FieldKind, params: dict | None = None, resolution=(7, 6, 5), **kw) -> Field:
    return Field(kind=kind, box_min=BOX_MIN, box_max=BOX_MAX, resolution=resolution,
                 params=params or {}, **kw)


def node_position(grid: FieldGrid, i: int, j: int, k: int) -> np.ndarray:
    lo, hi = np.array(grid.box_min), np.array(grid.box_max)
    return lo + np.array([i, j, k]) * (hi - lo) / (np.array(grid.resolution) - 1)


def linear_grid(resolution=(6, 5, 5)) -> FieldGrid:
    axes = [np.linspace(a, b, n) for a, b, n in zip(BOX_MIN, BOX_MAX, resolution, strict=True)]
    z, y, x = np.meshgrid(axes[2], axes[1], axes[0], indexing="ij")
    points = np.stack([x, y, z], axis=-1)
    return FieldGrid(points @ LINEAR.T + OFFSET, BOX_MIN, BOX_MAX)


def random_points(rng: np.random.Generator, n: int, margin: float = 0.0) -> np.ndarray:
    lo, hi = np.array(BOX_MIN) - margin, np.array(BOX_MAX) + margin
    return rng.uniform(lo, hi, size=(n, 3))


# --- building grids -----------------------------------------------------------------------


@pytest.mark.parametrize("kind, params", [
    (FieldKind.UNIFORM, {"velocity": (1.0, -2.0, 0.5)}),
    (FieldKind.VORTEX, VORTEX),
    (FieldKind.DOWNWASH, DOWNWASH),
])
def test_analytic_grid_layout(kind, params):
    grid = build_field(make_field(kind, params, resolution=(7, 6, 5)))
    assert grid.velocity.shape == (5, 6, 7, 3)
    assert grid.velocity.dtype == np.float32
    assert grid.velocity.flags["C_CONTIGUOUS"]
    assert not grid.velocity.flags["WRITEABLE"]
    assert grid.resolution == (7, 6, 5)
    assert len(grid.velocity.tobytes()) == 7 * 6 * 5 * 3 * 4
    assert np.isfinite(grid.velocity).all()
    assert grid.box_min == BOX_MIN and grid.box_max == BOX_MAX


def test_sampling_at_a_node_gives_the_node_value():
    grid = build_field(make_field(FieldKind.VORTEX, VORTEX, resolution=(9, 8, 7)))
    np.testing.assert_array_equal(sample_field(grid, [BOX_MIN], OutOfDomain.CLAMP)[0],
                                  grid.velocity[0, 0, 0])
    np.testing.assert_array_equal(sample_field(grid, [BOX_MAX], OutOfDomain.ZERO)[0],
                                  grid.velocity[-1, -1, -1])
    nodes = [(i, j, k) for i in range(9) for j in range(8) for k in range(7)]
    points = np.array([node_position(grid, *n) for n in nodes])
    expected = np.array([grid.velocity[k, j, i] for i, j, k in nodes], dtype=np.float64)
    np.testing.assert_allclose(sample_field(grid, points, OutOfDomain.CLAMP), expected,
                               rtol=1e-12, atol=1e-12)


def test_grid_nodes_hold_the_analytic_model():
    grid = build_field(make_field(FieldKind.VORTEX, VORTEX))
    point = node_position(grid, 4, 2, 3)
    exact = vortex_velocity(*point, VORTEX)
    np.testing.assert_allclose(grid.velocity[3, 2, 4], exact, rtol=1e-6)


def test_uniform_field_everywhere():
    grid = build_field(make_field(FieldKind.UNIFORM, {"velocity": (1.0, -2.0, 0.5)}))
    points = random_points(np.random.default_rng(1), 200, margin=1.0)
    np.testing.assert_allclose(sample_field(grid, points, OutOfDomain.CLAMP),
                               np.tile([1.0, -2.0, 0.5], (200, 1)), rtol=1e-12)


# --- vortex ----------------------------------------------------------------------------------


def test_vortex_is_tangential_and_counter_clockwise():
    rng = np.random.default_rng(2)
    x, y, z = rng.uniform(-3, 3, size=(3, 500))
    v = vortex_velocity(x, y, z, VORTEX)
    rx, ry = x - VORTEX["center"][0], y - VORTEX["center"][1]
    np.testing.assert_allclose(v[:, 0] * rx + v[:, 1] * ry, 0, atol=1e-12)
    assert (rx * v[:, 1] - ry * v[:, 0] > 0).all()  # z of r × v: counter-clockwise from above
    np.testing.assert_allclose(v[:, 2], VORTEX["axial_speed"])
    clockwise = vortex_velocity(x, y, z, {**VORTEX, "circulation": -2.0})
    assert (rx * clockwise[:, 1] - ry * clockwise[:, 0] < 0).all()


def test_vortex_profile_peaks_near_the_core_radius_and_vanishes_on_the_axis():
    core, (cx, cy) = VORTEX["core_radius"], VORTEX["center"]
    r = np.linspace(0.0, 5 * core, 20001)
    v = vortex_velocity(cx + r, cy, 0.0, VORTEX)
    assert np.isfinite(v).all()
    np.testing.assert_array_equal(v[0, :2], 0.0)
    speed = np.hypot(v[:, 0], v[:, 1])
    assert r[np.argmax(speed)] == pytest.approx(1.1209 * core, rel=1e-3)
    far = vortex_velocity(cx + 100.0, cy, 0.0, VORTEX)
    assert far[1] == pytest.approx(VORTEX["circulation"] / (2 * math.pi * 100.0), rel=1e-9)


def test_vortex_grid_through_the_axis_has_no_nan():
    field = Field(kind=FieldKind.VORTEX, box_min=(-1, -1, 0), box_max=(2, 1.5, 1),
                  resolution=(7, 6, 2), params={**VORTEX, "center": (0.0, 0.0)})
    grid = build_field(field)  # node (2, 2) sits on the axis
    assert np.isfinite(grid.velocity).all()
    np.testing.assert_array_equal(grid.velocity[:, 2, 2, :2], 0.0)


# --- downwash --------------------------------------------------------------------------------


def test_downwash_blows_down_under_the_disk_and_out_along_the_ground():
    cx, cy, cz = DOWNWASH["rotor_center"]
    mid = downwash_velocity(cx, cy, cz / 2, DOWNWASH)
    assert mid[2] < 0
    radius = DOWNWASH["rotor_radius"]
    for angle in np.linspace(0, 2 * math.pi, 8, endpoint=False):
        ex, ey = math.cos(angle), math.sin(angle)
        near_ground = downwash_velocity(cx + 2 * radius * ex, cy + 2 * radius * ey, 0.05, DOWNWASH)
        assert near_ground[0] * ex + near_ground[1] * ey > 0
    above = downwash_velocity(cx, cy, cz + 0.5, DOWNWASH)
    assert mid[2] < above[2] < 0
    np.testing.assert_array_equal(downwash_velocity(cx, cy, 0.0, DOWNWASH), 0.0)


def test_downwash_has_no_nan_anywhere():
    x = np.linspace(-4, 4, 33)[None, None, :]  # passes through r = 0
    z = np.linspace(-1, 8, 37)[:, None, None]  # below ground, ground, disk plane, above
    v = downwash_velocity(x, x.transpose(0, 2, 1), z, DOWNWASH)
    assert v.shape == (37, 33, 33, 3)
    assert np.isfinite(v).all()
    np.testing.assert_array_equal(v[z[:, 0, 0] < 0], 0.0)
    grid = build_field(Field(kind=FieldKind.DOWNWASH, box_min=(-4, -4, 0), box_max=(4, 4, 6),
                             resolution=(17, 17, 13), params=DOWNWASH))
    assert np.isfinite(grid.velocity).all()


# --- trilinear sampling ---------------------------------------------------------------------


def test_trilinear_reproduces_a_linear_field():
    grid = linear_grid()
    points = random_points(np.random.default_rng(3), 1000)
    np.testing.assert_allclose(sample_field(grid, points, OutOfDomain.CLAMP),
                               points @ LINEAR.T + OFFSET, rtol=0, atol=1e-13)


def test_trilinear_uses_the_textbook_weights():
    rng = np.random.default_rng(4)
    velocity = rng.integers(-8, 8, size=(4, 5, 6, 3)).astype(np.float32)
    grid = FieldGrid(velocity, (0.0, 0.0, 0.0), (5.0, 4.0, 3.0))  # unit cells
    p = rng.uniform(0, [5, 4, 3], size=(300, 3))
    i, t = np.minimum(np.floor(p), [4, 3, 2]).astype(int), p - np.minimum(np.floor(p), [4, 3, 2])
    expected = np.zeros((300, 3))
    for corner in np.ndindex(2, 2, 2):
        weight = np.prod(np.where(corner, t, 1 - t), axis=1)[:, None]
        expected += weight * velocity[i[:, 2] + corner[2], i[:, 1] + corner[1], i[:, 0] + corner[0]]
    np.testing.assert_allclose(sample_field(grid, p, OutOfDomain.CLAMP), expected, rtol=1e-13)


def test_outside_the_box_clamp_versus_zero():
    grid = linear_grid()
    rng = np.random.default_rng(5)
    points = random_points(rng, 400, margin=2.0)
    lo, hi = np.array(BOX_MIN), np.array(BOX_MAX)
    outside = ((points < lo) | (points > hi)).any(axis=1)
    assert outside.any() and (~outside).any()
    clamped = np.clip(points, lo, hi) @ LINEAR.T + OFFSET
    np.testing.assert_allclose(sample_field(grid, points, OutOfDomain.CLAMP), clamped, atol=1e-13)
    zero = sample_field(grid, points, "zero")
    np.testing.assert_array_equal(zero[outside], 0.0)
    np.testing.assert_allclose(zero[~outside], clamped[~outside], atol=1e-13)
    on_faces = np.array([BOX_MIN, BOX_MAX, [BOX_MIN[0], 0.0, 1.0]])  # the box is closed
    assert (np.abs(sample_field(grid, on_faces, OutOfDomain.ZERO)) > 0).any(axis=1).all()


def test_sampling_keeps_the_shape_of_points_and_turns_nan_into_nan():
    grid = linear_grid()
    assert sample_field(grid, np.zeros((2, 4, 3)), OutOfDomain.CLAMP).shape == (2, 4, 3)
    out = sample_field(grid, [[np.nan, 0, 0], [0, 0, 1]], OutOfDomain.ZERO)
    assert np.isnan(out[0]).all() and np.isfinite(out[1]).all()
    with pytest.raises(ValueError, match="shape"):
        sample_field(grid, np.zeros((4, 2)), OutOfDomain.CLAMP)


def test_float32_sampling_matches_float64():
    grid = build_field(make_field(FieldKind.VORTEX, VORTEX, resolution=(32, 24, 8)))
    points = random_points(np.random.default_rng(6), 2000, margin=0.5)
    for mode in OutOfDomain:
        single = sample_field(grid, points.astype(np.float32), mode, dtype=np.float32)
        assert single.dtype == np.float32
        np.testing.assert_allclose(single, sample_field(grid, points, mode), atol=1e-5)


# --- the .npz file edge ---------------------------------------------------------------------


def file_field(path, **kw) -> Field:
    return make_field(FieldKind.FILE, file=path, resolution=(2, 2, 2), **kw)


@pytest.mark.parametrize("dtype", [np.float16, np.float32, np.float64])
def test_field_file_round_trip(tmp_path, dtype):
    grid = build_field(make_field(FieldKind.VORTEX, VORTEX))
    path = tmp_path / "flow.field"
    save_field(path, grid)
    assert path.exists()  # no ".npz" appended
    loaded = build_field(file_field(path))
    np.testing.assert_array_equal(loaded.velocity, grid.velocity)
    assert loaded.resolution == grid.resolution and loaded.box_max == BOX_MAX
    np.savez(tmp_path / "plain.npz", velocity=grid.velocity.astype(dtype))  # no box arrays
    plain = build_field(file_field(tmp_path / "plain.npz"))
    np.testing.assert_array_equal(plain.velocity, grid.velocity.astype(dtype).astype(np.float32))


def write_npz(path, **arrays):
    np.savez(path, **arrays)
    return path


GOOD = np.zeros((3, 4, 5, 3), dtype=np.float32)
WITH_NAN = GOOD.copy()
WITH_NAN[1, 2, 3, 0] = np.nan
WITH_NAN[2, 0, 0, 2] = np.inf


@pytest.mark.parametrize("arrays, words", [
    ({"velocity": GOOD[..., 0]}, ["'velocity'", "(3, 4, 5)", "(nz, ny, nx, 3)"]),
    ({"velocity": GOOD[..., :2]}, ["'velocity'", "(3, 4, 5, 2)"]),
    ({"velocity": GOOD.astype(np.int32)}, ["'velocity'", "int32", "float"]),
    ({"velocity": GOOD.astype(bool)}, ["'velocity'", "bool"]),
    ({"velocity": GOOD.astype(np.complex64)}, ["'velocity'", "complex64"]),
    ({"velocity": WITH_NAN}, ["'velocity'", "2 non-finite", "(1, 2, 3, 0)"]),
    ({"velocity": np.full((2, 2, 2, 3), 1e39)}, ["'velocity'", "24 non-finite", "float32"]),
    ({"velocity": np.zeros((2, 2, 257, 3), np.float32)}, ["'velocity'", "257", "256"]),
    ({"velocity": np.zeros((1, 2, 2, 3), np.float32)}, ["'velocity'", "(1, 2, 2, 3)"]),
    ({"speed": GOOD}, ["missing array 'velocity'", "'speed'"]),
])
def test_bad_field_files_are_refused(tmp_path, arrays, words):
    path = write_npz(tmp_path / "bad.npz", **arrays)
    with pytest.raises(FieldError) as error:
        build_field(file_field(path))
    for word in [str(path), *words]:
        assert word in str(error.value)


def test_a_file_fields_grid_takes_the_fields_box_not_the_files(tmp_path):
    """The loader reads an .npz's box (tests/unit/test_scene_flow_files.py) and the scene's
    origin moves it; the grid does not read the file's world box again."""
    path = write_npz(tmp_path / "f.npz", velocity=GOOD, box_min=np.array(BOX_MIN) + 5000.0,
                     box_max=np.array(BOX_MAX) + 5000.0)
    grid = build_field(file_field(path))
    assert (grid.box_min, grid.box_max) == (BOX_MIN, BOX_MAX)


@pytest.mark.parametrize("content, words", [
    (b"this is not a zip archive", ["not", ".npz"]),
    (b"PK\x03\x04 truncated", [".npz"]),
])
def test_unreadable_field_files_are_refused(tmp_path, content, words):
    path = tmp_path / "broken.npz"
    path.write_bytes(content)
    with pytest.raises(FieldError, match="cannot read") as error:
        build_field(file_field(path))
    assert error.value.__cause__ is not None
    assert all(word in str(error.value) for word in [str(path), *words])


def test_missing_and_npy_field_files_are_refused(tmp_path):
    with pytest.raises(FieldError, match="cannot read") as error:
        build_field(file_field(tmp_path / "absent.npz"))
    assert isinstance(error.value.__cause__, OSError)
    np.save(tmp_path / "single.npy", GOOD)
    with pytest.raises(FieldError, match="single .npy array"):
        build_field(file_field(tmp_path / "single.npy"))
    with pytest.raises(FieldError, match="names no file"):
        build_field(file_field(None))


@pytest.mark.parametrize("field, words", [
    (make_field(FieldKind.VORTEX, {"center": (0, 0), "circulation": 1.0}), ["'core_radius'"]),
    (make_field(FieldKind.VORTEX, {**VORTEX, "core_radius": 0.0}), ["'core_radius'", "> 0"]),
    (make_field(FieldKind.UNIFORM, {"velocity": (1, 2)}), ["'velocity'", "3 numbers"]),
    (make_field(FieldKind.DOWNWASH, {**DOWNWASH, "ground_height": 4.0}), ["above ground"]),
    (make_field(FieldKind.UNIFORM, {"velocity": (0, 0, 0)}, resolution=(1, 4, 4)), ["[2, 256]"]),
    (Field(kind=FieldKind.UNIFORM, box_min=(0, 0, 1), box_max=(1, 1, 1), resolution=(2, 2, 2),
           params={"velocity": (0, 0, 0)}), ["box_max > box_min"]),
])
def test_bad_analytic_fields_are_refused(field, words):
    with pytest.raises(FieldError) as error:
        build_field(field)
    assert all(word in str(error.value) for word in words)


# --- height field ----------------------------------------------------------------------------

PLANE = (0.3, -0.2, 1.5)  # h = a x + b y + c
H_MIN, H_MAX = (-1.0, 2.0), (4.0, 5.0)


def plane_grid(nx: int = 11, ny: int = 7) -> HeightGrid:
    a, b, c = PLANE
    x, y = np.linspace(H_MIN[0], H_MAX[0], nx), np.linspace(H_MIN[1], H_MAX[1], ny)
    return HeightGrid(a * x[None, :] + b * y[:, None] + c, H_MIN, H_MAX)


def test_heightfield_round_trip(tmp_path):
    grid = plane_grid()
    assert grid.height.shape == (7, 11) and grid.height.dtype == np.float32
    assert grid.height.flags["C_CONTIGUOUS"] and grid.resolution == (11, 7)
    save_heightfield(tmp_path / "ground.hf", grid)
    loaded = load_heightfield(tmp_path / "ground.hf")
    np.testing.assert_array_equal(loaded.height, grid.height)
    assert (loaded.box_min, loaded.box_max) == (H_MIN, H_MAX)


def test_bilinear_height_and_normal_of_a_plane():
    a, b, c = PLANE
    grid = plane_grid()
    xy = np.random.default_rng(7).uniform(H_MIN, H_MAX, size=(500, 2))
    height, normal = sample_height(grid, xy)
    np.testing.assert_allclose(height, a * xy[:, 0] + b * xy[:, 1] + c, atol=1e-6)
    expected = np.array([-a, -b, 1.0]) / math.sqrt(a * a + b * b + 1)
    np.testing.assert_allclose(normal, np.tile(expected, (500, 1)), atol=1e-6)
    np.testing.assert_allclose(np.linalg.norm(normal, axis=1), 1.0, rtol=1e-12)


def test_height_outside_the_box_continues_the_edge():
    a, b, c = PLANE
    grid = plane_grid()
    height, normal = sample_height(grid, [[10.0, 3.0], [-5.0, 100.0], [np.nan, 3.0]])
    np.testing.assert_allclose(height[:2], [a * 4 + b * 3 + c, a * -1 + b * 5 + c], atol=1e-6)
    np.testing.assert_allclose(normal[0], np.array([0, -b, 1]) / math.hypot(b, 1), atol=1e-6)
    np.testing.assert_array_equal(normal[1], [0, 0, 1])
    assert np.isnan(height[2]) and np.isnan(normal[2]).all()


def test_height_sampling_at_nodes_and_in_float32():
    rng = np.random.default_rng(8)
    grid = HeightGrid(rng.normal(size=(9, 13)), H_MIN, H_MAX)
    np.testing.assert_array_equal(sample_height(grid, [H_MIN])[0], grid.height[0, 0])
    np.testing.assert_array_equal(sample_height(grid, [H_MAX])[0], grid.height[-1, -1])
    xy = rng.uniform(np.array(H_MIN) - 1, np.array(H_MAX) + 1, size=(2000, 2))
    h64, n64 = sample_height(grid, xy)
    h32, n32 = sample_height(grid, xy.astype(np.float32), dtype=np.float32)
    assert h32.dtype == n32.dtype == np.float32
    np.testing.assert_allclose(h32, h64, atol=1e-5)
    np.testing.assert_allclose(n32, n64, atol=1e-5)


@pytest.mark.parametrize("arrays, words", [
    ({"height": np.zeros((3, 4)), "box_min": [0, 0]}, ["missing array 'box_max'"]),
    ({"height": np.zeros((3, 4)), "box_min": [0, 0], "box_max": [1, 0]}, ["box_max > box_min"]),
    ({"height": np.zeros((3, 4), int), "box_min": [0, 0], "box_max": [1, 1]}, ["'height'", "int"]),
    ({"height": np.zeros((1, 4)), "box_min": [0, 0], "box_max": [1, 1]}, ["'height'", "(1, 4)"]),
    ({"height": np.zeros((3, 4, 1)), "box_min": [0, 0], "box_max": [1, 1]}, ["(ny, nx)"]),
    ({"height": np.zeros((2, 4097)), "box_min": [0, 0], "box_max": [1, 1]}, ["4097", "4096"]),
    ({"height": np.array([[0, np.nan], [1, 1.0]]), "box_min": [0, 0], "box_max": [1, 1]},
     ["'height'", "1 non-finite", "(0, 1)"]),
    ({"height": np.zeros((3, 4)), "box_min": [0, 0, 0], "box_max": [1, 1]}, ["'box_min'", "2"]),
])
def test_bad_heightfield_files_are_refused(tmp_path, arrays, words):
    path = write_npz(tmp_path / "bad.npz", **arrays)
    with pytest.raises(FieldError) as error:
        load_heightfield(path)
    assert all(word in str(error.value) for word in [str(path), *words])
