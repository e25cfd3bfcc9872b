"""The world behind the dust: a sky graded from horizon to zenith with the sun where its
direction points, a helicopter of the expected shape, and ground that fades into the
horizon's colour with distance."""

import numpy as np
from render_helpers import small_cave
from scenes import make_scene

from cavesim.core.scene_frame import HelicopterPose
from cavesim.gpu.engine import ParticleSystem
from cavesim.gpu.render.wall_renderer import RenderSettings, WallRenderer

EYE = np.array([0.0, 0.0, 1.5])  # level with the middle row of a 3 m high wall
PLANE = {"kind": "plane", "friction": 0.3, "resilience": 0.4}  # ground at z = 0, +-30 m


def front(ctx, ground: bool, helicopter=None, size: int = 240, **settings) -> np.ndarray:
    """The front wall (y = 1.5 m, x and z from -1.5 and 0 to 1.5 and 3 m) without dust."""
    system = ParticleSystem(ctx, make_scene(drag=False, collision=PLANE if ground else None,
                                            capacity=10))
    wall = small_cave(resolution=(size, size)).wall("front")
    return WallRenderer(ctx, system, wall, RenderSettings(**settings)).render(EYE, helicopter)


def pixel_of(point, size: int) -> tuple[float, float]:
    """(row, column) where the ray from EYE through a world point crosses the front wall."""
    on_wall = EYE + (np.asarray(point, float) - EYE) * (1.5 - EYE[1]) / (point[1] - EYE[1])
    return (3.0 - on_wall[2]) / 3.0 * size - 0.5, (on_wall[0] + 1.5) / 3.0 * size - 0.5


def test_the_sky_is_bluer_and_darker_above_the_horizon(ctx):
    sky = front(ctx, ground=False).astype(float)
    rows = sky[:, 100:140].mean(axis=1)  # away from the sun's glow
    horizon, high = rows[118], rows[10]  # 0 and 45 degrees up
    assert high.sum() < horizon.sum() - 60, (high, horizon)
    assert high[2] - high[0] > horizon[2] - horizon[0] + 30, (high, horizon)
    brightness = rows[:120].sum(axis=1)
    assert (np.diff(brightness) >= -1).all(), "brighter all the way down to the horizon"
    below = sky[125:, :].reshape(-1, 3)
    assert np.abs(below - np.asarray(RenderSettings().sky) * 255).max() <= 1, \
        "the horizon's colour below it"


def test_the_sun_is_drawn_where_its_direction_points(ctx):
    target = np.array([0.6, 1.5, 2.4])  # a point on the front wall
    sun = target - EYE
    picture = front(ctx, ground=False, sun_direction=tuple(sun))
    sun_color = np.asarray(RenderSettings().sun_color) * 255
    disc = (picture >= sun_color - 3).all(axis=2)
    rows, columns = np.nonzero(disc)
    expected = pixel_of(target, 240)
    assert np.hypot(rows.mean() - expected[0], columns.mean() - expected[1]) < 1.0, \
        ((rows.mean(), columns.mean()), expected)
    radius = np.sqrt(disc.sum() / np.pi)  # px: 1.6 degrees is about 4 px here
    assert 2 < radius < 8, radius  # a disc, not a pixel and not the sky


def test_a_helicopter_seen_side_on_has_its_tail_behind_and_skids_below(ctx):
    """Nose toward +x, 6 m in front of the wall, the rotor disc edge-on at eye height: the
    silhouette below the disc reaches much farther behind the hub than ahead of it, and
    under the hub it crosses the belly and then, below a gap of sky, a skid whose sole is
    at the pose's height."""
    size, position = 480, np.array([0.3, 7.5, EYE[2] - 1.3])
    pose = HelicopterPose(tuple(position), 0.0, 0.3)
    clear = front(ctx, ground=False, size=size).astype(int)
    drawn = front(ctx, ground=False, helicopter=pose, size=size).astype(int)
    body = np.abs(drawn - clear).max(axis=2) > 40
    hub_row, hub_column = pixel_of(position + [0, 0, pose.hub_height], size)
    body[:round(hub_row) + 3] = False  # the disc, a line along the hub's row, and above
    rows, columns = np.nonzero(body)
    behind, ahead = hub_column - columns.min(), columns.max() - hub_column
    assert behind > 2.0 * ahead > 0, (behind, ahead)
    sole_row = pixel_of(position, size)[0]
    assert abs(rows.max() - sole_row) < 2.0, (rows.max(), sole_row)
    column = body[:, round(hub_column)]
    runs = np.flatnonzero(np.diff(np.r_[0, column.astype(int), 0]))
    starts = runs[::2]
    assert len(starts[starts > hub_row]) >= 2, f"belly and skid: runs from rows {runs}"


def test_the_ground_fades_into_the_horizon_with_distance(ctx):
    horizon = np.asarray(RenderSettings().sky) * 255

    def distance_to_horizon(**settings) -> tuple[float, float]:
        picture = front(ctx, ground=True, **settings).astype(float)
        rows = np.abs(picture - horizon).max(axis=2).mean(axis=1)
        return rows[-1], rows[128]  # the ground 1.5 m and 21 m away

    near, far = distance_to_horizon(fog_distance=12.0)
    assert near > 60 and far < 0.35 * near, (near, far)
    clear_near, clear_far = distance_to_horizon(fog_distance=1e9)
    assert clear_far > 0.8 * clear_near, (clear_near, clear_far)
