"""Smooth interpolation of gridded flows (cavesim/core/fields/interpolation.py): Catmull-Rom
(C1) and the prefiltered cubic B-spline (C2) beside trilinear, in the float64 twin
`sample_field`."""

from __future__ import annotations

import numpy as np
import pytest

from cavesim.core.fields.analytic import vortex_velocity
from cavesim.core.fields.grid import FieldGrid, build_field, sample_field, save_field
from cavesim.core.fields.interpolation import axis_map, weights
from cavesim.core.scene.model import Field, FieldInterpolation, FieldKind, OutOfDomain

TRILINEAR, CATMULL_ROM, BSPLINE = FieldInterpolation
CUBICS = (CATMULL_ROM, BSPLINE)
SMOOTHNESS = {CATMULL_ROM: 1, BSPLINE: 2}  # C^k across cell faces
ORDER = {TRILINEAR: 2, CATMULL_ROM: 3, BSPLINE: 4}  # interpolation error O(h^order)
DEGREE = {CATMULL_ROM: 2, BSPLINE: 3}  # polynomials reproduced exactly, up to the box faces
BOX_MIN, BOX_MAX = (-2.0, -1.5, 0.0), (3.0, 2.5, 2.0)
VORTEX = {"center": (0.3, -0.2), "circulation": 2.0, "core_radius": 1.0, "axial_speed": 0.0}


def grid_of(function, resolution, interpolation) -> FieldGrid:
    """The grid of `function(x, y, z) -> (..., 3)` at the nodes of the test box."""
    axes = [np.linspace(a, b, n) for a, b, n in zip(BOX_MIN, BOX_MAX, resolution, strict=True)]
    z, y, x = np.meshgrid(axes[2], axes[1], axes[0], indexing="ij")
    return FieldGrid(function(x, y, z), BOX_MIN, BOX_MAX, interpolation)


def polynomial(degrees):
    """A flow whose component i is a polynomial of degree degrees[a] in coordinate a."""
    def flow(x, y, z):
        dx, dy, dz = degrees
        return np.stack([x**dx - 0.5 * y**dy + 0.25 * z**dz + 1.0,
                         (x**dx) * (y**dy) - z**dz,
                         0.5 * (y**dy) * (z**dz) + x], axis=-1)
    return flow


def box_points(rng: np.random.Generator, n: int, margin: float = 0.0) -> np.ndarray:
    return rng.uniform(np.array(BOX_MIN) - margin, np.array(BOX_MAX) + margin, size=(n, 3))


def derivative_jumps(interpolation: FieldInterpolation, texels: np.ndarray) -> np.ndarray:
    """|jump| of the d-th derivative (d = 0..3) of the 1D interpolant at the face between
    the cell of texels[0:4] and the cell of texels[1:5]."""
    t = np.linspace(0.0, 1.0, 9)
    coefficients = np.polynomial.polynomial.polyfit(t, np.stack(weights(t, interpolation)).T, 3)
    jumps = []
    for d in range(4):
        derived = np.polynomial.polynomial.polyder(coefficients, d)
        at = np.polynomial.polynomial.polyval  # weights' d-th derivatives at t = 1 and t = 0
        left, right = at(1.0, derived) @ texels[0:4], at(0.0, derived) @ texels[1:5]
        jumps.append(abs(left - right))
    return np.array(jumps)


# --- the interpolants -------------------------------------------------------------------------


@pytest.mark.parametrize("interpolation", CUBICS)
def test_each_cubic_is_exactly_as_smooth_as_claimed(interpolation):
    rng = np.random.default_rng(1)
    k = SMOOTHNESS[interpolation]
    for texels in rng.normal(size=(20, 5)):
        jumps = derivative_jumps(interpolation, texels)
        assert (jumps[:k + 1] < 1e-9).all(), jumps  # C^k: values and k derivatives agree
        assert jumps[k + 1] > 1e-3, jumps  # and no more: the next derivative jumps


@pytest.mark.parametrize("interpolation", CUBICS)
def test_weights_are_integer_polynomials_summing_to_their_factor(interpolation):
    t = np.linspace(0.0, 1.0, 33)
    factor = {CATMULL_ROM: 2, BSPLINE: 6}[interpolation]
    np.testing.assert_allclose(sum(weights(t, interpolation)), factor, rtol=1e-15)
    at_node = [float(w[0]) for w in weights(t, interpolation)]
    assert at_node == ([0.0, 2.0, 0.0, 0.0] if interpolation is CATMULL_ROM
                       else [1.0, 4.0, 1.0, 0.0])  # the B-spline's (1, 4, 1) / 6 at a node


@pytest.mark.parametrize("interpolation", CUBICS)
def test_texels_pad_every_axis_with_one_ghost_at_each_end(interpolation):
    velocity = np.random.default_rng(2).normal(size=(4, 5, 6, 3)).astype(np.float32)
    grid = FieldGrid(velocity, BOX_MIN, BOX_MAX, interpolation)
    assert grid.texels.shape == (6, 7, 8, 3) and grid.texture_size == (8, 7, 6)
    assert grid.texels.dtype == np.float32 and grid.texels.flags["C_CONTIGUOUS"]
    assert not grid.texels.flags["WRITEABLE"]
    assert grid.resolution == (6, 5, 4)
    if interpolation is CATMULL_ROM:  # the nodes / 8 inside, exactly
        np.testing.assert_array_equal(grid.texels[1:-1, 1:-1, 1:-1], velocity / 8)


def test_trilinear_texels_are_the_nodes():
    grid = grid_of(polynomial((1, 1, 1)), (3, 4, 5), TRILINEAR)
    assert grid.texels is grid.velocity and grid.texture_size == grid.resolution


@pytest.mark.parametrize("n", [2, 3, 4, 5, 12])
def test_axis_maps_close_the_ends_as_keys_and_not_a_knot(n):
    nodes = np.arange(n, dtype=np.float64)
    quadratic, cubic = 0.5 * nodes**2 - nodes + 2, nodes**3 - 2 * nodes**2
    ghosts = axis_map(n, CATMULL_ROM) @ quadratic
    if n >= 3:  # Keys' boundary rule: the parabola through the three end nodes, continued
        assert ghosts[0] == pytest.approx(3 * quadratic[0] - 3 * quadratic[1] + quadratic[2])
        assert ghosts[-1] == pytest.approx(0.5 * n**2 - n + 2)
    else:
        assert ghosts[0] == pytest.approx(2 * quadratic[0] - quadratic[1])
    coefficients = axis_map(n, BSPLINE) @ cubic
    inner = (coefficients[:-2] + 4 * coefficients[1:-1] + coefficients[2:]) / 6
    np.testing.assert_allclose(inner, cubic, atol=1e-12)  # it interpolates the nodes
    if n >= 4:  # not-a-knot: the fourth difference at each end vanishes
        assert abs(np.diff(coefficients[:5], 4)[0]) < 1e-10
        assert abs(np.diff(coefficients[-5:], 4)[0]) < 1e-10


# --- sampling -----------------------------------------------------------------------------------


@pytest.mark.parametrize("interpolation", CUBICS)
def test_cubics_pass_through_the_nodes(interpolation):
    velocity = np.random.default_rng(3).normal(size=(4, 5, 6, 3)).astype(np.float32)
    grid = FieldGrid(velocity, BOX_MIN, BOX_MAX, interpolation)
    axes = [np.linspace(a, b, n) for a, b, n in zip(BOX_MIN, BOX_MAX, (6, 5, 4), strict=True)]
    z, y, x = np.meshgrid(axes[2], axes[1], axes[0], indexing="ij")
    nodes = np.stack([x, y, z], axis=-1)
    tolerance = 0 if interpolation is CATMULL_ROM else 1e-5  # B-spline: float32 coefficients
    np.testing.assert_allclose(sample_field(grid, nodes, OutOfDomain.CLAMP), velocity,
                               rtol=0, atol=tolerance)


@pytest.mark.parametrize("resolution", [(2, 3, 2), (3, 4, 3), (4, 5, 6), (9, 7, 8)])
@pytest.mark.parametrize("interpolation", CUBICS)
def test_cubics_reproduce_their_polynomials_up_to_the_faces(interpolation, resolution):
    """Quadratics (Catmull-Rom) and cubics (B-spline) per axis, or the polynomial through
    all nodes of a shorter axis; points fill the whole box, its boundary cells included."""
    degrees = tuple(min(DEGREE[interpolation], n - 1) for n in resolution)
    flow = polynomial(degrees)
    grid = grid_of(flow, resolution, interpolation)
    points = box_points(np.random.default_rng(4), 2000)
    expected = flow(*points.T)
    np.testing.assert_allclose(sample_field(grid, points, OutOfDomain.CLAMP), expected,
                               rtol=0, atol=2e-5 * np.abs(expected).max())


def test_interpolation_error_falls_with_the_interpolants_order():
    """A Lamb-Oseen vortex on grids of 33 and 65 nodes: the error ratio gives the order."""
    points = np.random.default_rng(5).uniform((-2, -2, 0), (2, 2, 1), size=(4000, 3))
    exact = vortex_velocity(*points.T, VORTEX)
    for interpolation, order in ORDER.items():
        errors = []
        for n in (33, 65):
            field = Field(kind=FieldKind.VORTEX, box_min=(-4, -4, 0), box_max=(4, 4, 1),
                          resolution=(n, n, 2), params=VORTEX, interpolation=interpolation)
            sampled = sample_field(build_field(field), points, OutOfDomain.CLAMP)
            errors.append(np.abs(sampled - exact).max())
        assert np.log2(errors[0] / errors[1]) == pytest.approx(order, abs=0.3), interpolation


@pytest.mark.parametrize("interpolation", CUBICS)
def test_cubics_keep_the_out_of_domain_rules(interpolation):
    """CLAMP: the flow of the nearest boundary point; ZERO: still air outside the closed box."""
    flow = polynomial((1, 1, 1))
    grid = grid_of(flow, (5, 4, 6), interpolation)
    points = box_points(np.random.default_rng(6), 400, margin=2.0)
    lo, hi = np.array(BOX_MIN), np.array(BOX_MAX)
    outside = ((points < lo) | (points > hi)).any(axis=1)
    assert outside.any() and (~outside).any()
    clamped = flow(*np.clip(points, lo, hi).T)
    np.testing.assert_allclose(sample_field(grid, points, OutOfDomain.CLAMP), clamped,
                               atol=1e-5)
    zero = sample_field(grid, points, OutOfDomain.ZERO)
    np.testing.assert_array_equal(zero[outside], 0.0)
    np.testing.assert_allclose(zero[~outside], clamped[~outside], atol=1e-5)
    on_faces = np.array([BOX_MIN, BOX_MAX, [BOX_MIN[0], 0.0, 1.0]])
    np.testing.assert_allclose(sample_field(grid, on_faces, OutOfDomain.ZERO),
                               flow(*on_faces.T), atol=1e-5)
    out = sample_field(grid, [[np.nan, 0, 0], [0, 0, 1]], OutOfDomain.ZERO)
    assert np.isnan(out[0]).all() and np.isfinite(out[1]).all()


@pytest.mark.parametrize("interpolation", CUBICS)
def test_float32_sampling_matches_float64(interpolation):
    field = Field(kind=FieldKind.VORTEX, box_min=BOX_MIN, box_max=BOX_MAX,
                  resolution=(32, 24, 8), params=VORTEX, interpolation=interpolation)
    grid = build_field(field)
    points = box_points(np.random.default_rng(7), 2000, margin=0.5)
    for mode in OutOfDomain:
        single = sample_field(grid, points.astype(np.float32), mode, dtype=np.float32)
        assert single.dtype == np.float32
        np.testing.assert_allclose(single, sample_field(grid, points, mode), atol=1e-5)


def test_a_field_file_is_interpolated_as_the_scene_asks(tmp_path):
    nodes = grid_of(polynomial((2, 2, 2)), (5, 5, 5), TRILINEAR)
    path = tmp_path / "flow.npz"
    save_field(path, nodes)
    point = [[0.1, 0.2, 0.3]]
    for interpolation in FieldInterpolation:
        field = Field(kind=FieldKind.FILE, box_min=BOX_MIN, box_max=BOX_MAX,
                      resolution=(2, 2, 2), file=path, interpolation=interpolation)
        grid = build_field(field)
        assert grid.interpolation is interpolation
        error = abs(sample_field(grid, point, OutOfDomain.CLAMP) - polynomial((2, 2, 2))(
            *np.transpose(point))).max()
        assert (error > 1e-3) == (interpolation is TRILINEAR)  # the cubics hold quadratics
