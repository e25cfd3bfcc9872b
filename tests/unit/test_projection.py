"""Off-axis projection: hand-computed frusta, pixel corners, seams between walls, eyes."""

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cavesim.core.cave import (
    DEFAULT_CAVE,
    Wall,
    eye_positions,
    gl_matrix,
    load_cave,
    matrices_for_gl,
    off_axis,
    project_to_pixels,
    recut,
)

ROOT = Path(__file__).resolve().parents[2]
FLEX = load_cave(ROOT / DEFAULT_CAVE)
NEAR, FAR = 0.05, 200.0
# a 2 m x 2 m wall in the plane y = 1, bottom on the floor; its normal is -y
WALL = Wall("w", [-1.0, 1.0, 0.0], [1.0, 1.0, 0.0], [-1.0, 1.0, 2.0], (200, 200))


def gl_frustum(left, right, bottom, top, n, f):
    """The glFrustum matrix as the OpenGL 2.1 reference page writes it."""
    r, lf, t, b = right, left, top, bottom
    return np.array([
        [2 * n / (r - lf), 0, (r + lf) / (r - lf), 0],
        [0, 2 * n / (t - b), (t + b) / (t - b), 0],
        [0, 0, -(f + n) / (f - n), -2 * f * n / (f - n)],
        [0, 0, -1, 0],
    ], dtype=np.float64)


def h(p):
    return np.append(np.asarray(p, dtype=np.float64), 1.0)


def test_centred_eye_gives_a_symmetric_frustum():
    eye = [0.0, 0.0, 1.0]  # 1 m in front of the wall's centre
    P, V = off_axis(WALL, eye, NEAR, FAR)
    assert P.shape == V.shape == (4, 4) and P.dtype == V.dtype == np.float64
    np.testing.assert_allclose(P, gl_frustum(-NEAR, NEAR, -NEAR, NEAR, NEAR, FAR), atol=1e-15)
    np.testing.assert_allclose(V @ h(eye), [0, 0, 0, 1], atol=1e-15)
    np.testing.assert_allclose(V @ h(WALL.center), [0, 0, -1, 1], atol=1e-15)


def test_off_centre_eye_gives_the_hand_computed_frustum():
    # eye 0.5 m from the plane; relative to it the wall spans x in [-1.5, 0.5] and
    # z in [-0.25, 1.75], so at the near plane l, r, b, t = (-1.5, 0.5, -0.25, 1.75) * n/0.5
    P, V = off_axis(WALL, [0.5, 0.5, 0.25], NEAR, FAR)
    n = NEAR
    np.testing.assert_allclose(P, gl_frustum(-3 * n, n, -0.5 * n, 3.5 * n, n, FAR), atol=1e-15)
    # rows of the rotation: right = +x, up = +z, normal = -y
    np.testing.assert_allclose(V[:3, :3], [[1, 0, 0], [0, 0, 1], [0, -1, 0]], atol=0)
    np.testing.assert_allclose(V[:3, 3], [-0.5, -0.25, 0.5])


def test_wall_corners_land_on_the_ndc_square():
    P, V = off_axis(WALL, [0.3, -0.7, 1.6])
    for corner, expected in zip(WALL.corners, [(-1, -1), (1, -1), (1, 1), (-1, 1)], strict=True):
        clip = P @ V @ h(corner)
        np.testing.assert_allclose(clip[:2] / clip[3], expected, atol=1e-12)
        assert -1 < clip[2] / clip[3] < 1


@settings(max_examples=200, deadline=None)
@given(x=st.floats(-3, 3), y=st.floats(-5, 0.99), z=st.floats(-3, 5))
def test_wall_corners_project_to_pixel_corners(x, y, z):
    px = project_to_pixels(WALL, [x, y, z], WALL.corners)
    np.testing.assert_allclose(px, [[0, 0], [200, 0], [200, 200], [0, 200]], atol=1e-6)


def test_a_recut_frustum_is_the_frustum_with_other_clip_planes():
    eye = [0.5, 0.5, 0.25]
    P, _ = off_axis(WALL, eye, NEAR, FAR)
    np.testing.assert_allclose(recut(P, 1e-4, 50.0), off_axis(WALL, eye, 1e-4, 50.0)[0],
                               rtol=1e-12, atol=1e-15)
    with pytest.raises(ValueError, match="0 < near < far"):
        recut(P, 0.0, FAR)


def test_points_behind_the_eye_are_nan():
    px = project_to_pixels(WALL, [0, 0, 1], [[0, 1, 1], [0, -1, 1], [0, 0, 1]])
    np.testing.assert_allclose(px[0], [100, 100])
    assert np.isnan(px[1:]).all()


def test_eye_on_or_behind_the_wall_is_refused():
    for eye in ([0, 1, 1], [0, 2, 1]):
        with pytest.raises(ValueError, match=r"eye = \[0\.0, [12]\.0, 1\.0\].*wall 'w'"):
            off_axis(WALL, eye)
    with pytest.raises(ValueError, match="eye must be 3 finite"):
        off_axis(WALL, [0, np.nan, 1])
    with pytest.raises(ValueError, match="near and far"):
        off_axis(WALL, [0, 0, 1], near=0.0)


inside = st.tuples(st.floats(-1.4, 1.4), st.floats(-1.4, 1.4), st.floats(0.1, 2.9))


@settings(max_examples=300, deadline=None)
@given(eye=inside, height=st.floats(0, 3), ts=st.lists(st.floats(0.05, 20), min_size=1,
                                                      max_size=8))
def test_front_left_seam_is_continuous(eye, height, ts):
    front, left = FLEX.wall("front"), FLEX.wall("left")
    edge = np.array([-1.5, 1.5, height])
    on_front = project_to_pixels(front, eye, [edge])[0]
    on_left = project_to_pixels(left, eye, [edge])[0]
    assert abs(on_front[0] - 0) < 1e-6 and abs(on_left[0] - 480) < 1e-6
    assert abs(on_front[1] - on_left[1]) < 1e-6
    assert abs(on_front[1] - height / 3 * 480) < 1e-6
    # any point on the ray from the eye through the edge, inside the room or beyond the
    # corner, lands on the seam of both walls at that same height
    ray = np.asarray(eye) + np.outer(ts, edge - np.asarray(eye))
    f, lft = project_to_pixels(front, eye, ray), project_to_pixels(left, eye, ray)
    np.testing.assert_allclose(f[:, 0], 0, atol=1e-6)
    np.testing.assert_allclose(lft[:, 0], 480, atol=1e-6)
    np.testing.assert_allclose(f[:, 1], lft[:, 1], atol=1e-6)
    np.testing.assert_allclose(f[:, 1], on_front[1], atol=1e-6)


@settings(max_examples=300, deadline=None)
@given(eye=inside, across=st.floats(-1.5, 1.5), ts=st.lists(st.floats(0.05, 20), min_size=1,
                                                            max_size=8))
def test_front_floor_seam_is_continuous(eye, across, ts):
    front, floor = FLEX.wall("front"), FLEX.wall("floor")
    edge = np.array([across, 1.5, 0.0])
    ray = np.vstack([edge, np.asarray(eye) + np.outer(ts, edge - np.asarray(eye))])
    f, fl = project_to_pixels(front, eye, ray), project_to_pixels(floor, eye, ray)
    np.testing.assert_allclose(f[:, 1], 0, atol=1e-6)
    np.testing.assert_allclose(fl[:, 1], 480, atol=1e-6)
    np.testing.assert_allclose(f[:, 0], fl[:, 0], atol=1e-6)
    np.testing.assert_allclose(f[:, 0], (across + 1.5) / 3 * 480, atol=1e-6)


@settings(max_examples=100, deadline=None)
@given(eye=inside, point=st.tuples(st.floats(-1.5, 1.5), st.floats(-1.5, 1.5),
                                   st.floats(0, 3)))
def test_a_point_near_the_seam_is_seen_by_exactly_one_side(eye, point):
    # a point's image is on the front wall exactly when its image on the left wall is off
    # it (to the right of x = 480): the two images never overlap or leave a gap
    front, left = FLEX.wall("front"), FLEX.wall("left")
    f = project_to_pixels(front, eye, [point])[0]
    lft = project_to_pixels(left, eye, [point])[0]
    if np.isnan(f).any() or np.isnan(lft).any() or abs(f[0]) < 1e-6:
        return
    assert (f[0] > 0) == (lft[0] > 480)


def _rotate(q, v):
    """v rotated by the unit quaternion q = (x, y, z, w) as q v q*."""
    x, y, z, w = q
    u = np.array([x, y, z])
    return v + 2 * np.cross(u, np.cross(u, v) + w * v)


def test_mono_is_the_head_itself():
    eyes = eye_positions([0.1, 0.2, 1.7], [0, 0, 0, 1])
    assert list(eyes) == ["center"]
    np.testing.assert_array_equal(eyes["center"], [0.1, 0.2, 1.7])


def test_stereo_eyes_with_head_turned_left():
    s = np.sqrt(0.5)  # 90 degrees about +z: the head looks along -x, its right is +y
    eyes = eye_positions([0, 0, 1.7], [0, 0, s, s], ipd=0.064, stereo=True)
    np.testing.assert_allclose(eyes["left"], [0, -0.032, 1.7], atol=1e-15)
    np.testing.assert_allclose(eyes["right"], [0, 0.032, 1.7], atol=1e-15)


@settings(max_examples=200, deadline=None)
@given(q=st.tuples(*[st.floats(-1, 1)] * 4).filter(lambda q: np.linalg.norm(q) > 1e-3),
       scale=st.floats(0.1, 10), ipd=st.floats(0.05, 0.08))
def test_stereo_eyes_are_ipd_apart_along_the_heads_right_axis(q, scale, ipd):
    head = np.array([0.2, -0.4, 1.6])
    eyes = eye_positions(head, np.asarray(q) * scale, ipd=ipd, stereo=True)
    axis = _rotate(np.asarray(q) / np.linalg.norm(q), np.array([1.0, 0, 0]))
    np.testing.assert_allclose(eyes["right"] - eyes["left"], ipd * axis, atol=1e-12)
    np.testing.assert_allclose((eyes["left"] + eyes["right"]) / 2, head, atol=1e-12)


def test_bad_head_is_refused():
    with pytest.raises(ValueError, match="head_orientation_xyzw"):
        eye_positions([0, 0, 1.7], [0, 0, 0, 0], stereo=True)
    with pytest.raises(ValueError, match="head_orientation_xyzw"):
        eye_positions([0, 0, 1.7], [0, 0, np.nan, 1])
    with pytest.raises(ValueError, match="head_position"):
        eye_positions([0, np.inf, 1.7], [0, 0, 0, 1])
    with pytest.raises(ValueError, match="ipd"):
        eye_positions([0, 0, 1.7], [0, 0, 0, 1], ipd=-0.06, stereo=True)


def test_matrices_for_gl_are_float32_column_major():
    P, V = off_axis(WALL, [0.5, 0.5, 0.25])
    raw = matrices_for_gl(P, V)
    assert len(raw) == 128
    m = np.frombuffer(raw, dtype="<f4").reshape(2, 4, 4)
    np.testing.assert_allclose(m[0].T, P, rtol=1e-6)
    np.testing.assert_allclose(m[1][3, :3], V[:3, 3], rtol=1e-6)  # translation is column 3
    assert gl_matrix(P) == raw[:64]
    with pytest.raises(ValueError, match=r"\(4, 4\).*\(3, 3\)"):
        gl_matrix(np.eye(3))
