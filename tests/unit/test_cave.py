"""CAVE geometry files: the shipped configs, and the loader's refusal of broken walls."""

import dataclasses
import math
import tomllib
from pathlib import Path

import numpy as np
import pytest

from cavesim.core.cave import DEFAULT_CAVE, Cave, Wall, load_cave, parse_cave
from cavesim.core.cave.desktop import WINDOW_GAP, desktop_cave_file
from cavesim.core.errors import CaveError

ROOT = Path(__file__).resolve().parents[2]
SHIPPED = sorted((ROOT / "config" / "cave").glob("*.toml"))
ROOM_CENTRE = np.array([0.0, 0.0, 1.5])

FRONT = {
    "name": "front",
    "lower_left": [-1.5, 1.5, 0.0],
    "lower_right": [1.5, 1.5, 0.0],
    "upper_left": [-1.5, 1.5, 3.0],
    "upper_right": [1.5, 1.5, 3.0],
    "resolution": [480, 480],
}


def _toml(v: object) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float) and not math.isfinite(v):
        return "nan" if math.isnan(v) else ("inf" if v > 0 else "-inf")
    if isinstance(v, str):
        return '"' + v + '"'
    if isinstance(v, list):
        return "[" + ", ".join(_toml(x) for x in v) + "]"
    return repr(v)


def write_cave(path: Path, walls: list[dict], **top: object) -> Path:
    """A cave file at `path` with `top` keys and one [[wall]] table per dict."""
    lines = [f"{k} = {_toml(v)}" for k, v in top.items()]
    for w in walls:
        lines += ["", "[[wall]]"] + [f"{k} = {_toml(v)}" for k, v in w.items()]
    path.write_text("\n".join(lines) + "\n")
    return path


def test_default_is_flex4():
    assert DEFAULT_CAVE == "config/cave/flex4.toml"
    cave = load_cave(ROOT / DEFAULT_CAVE)
    assert cave.name == "flex4"
    assert cave.names == ("front", "left", "right", "floor")


def test_shipped_configs_are_the_four_expected():
    assert [p.stem for p in SHIPPED] == ["flex4", "flex4_hd", "power_wall", "six_sided",
                                         "two_gpus"]


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: p.stem)
def test_every_shipped_cave_shows_how_a_wall_is_displayed(path):
    """Each file gives a [wall.display] example, commented out or in use."""
    text = path.read_text()
    assert "[wall.display]" in text or "display = {" in text


def test_the_two_gpu_cave_gives_each_gpu_a_node_of_two_walls_on_its_own_screen():
    cave = load_cave(ROOT / "config" / "cave" / "two_gpus.toml")
    assert cave.nodes == {"gpu0": ("front", "left"), "gpu1": ("right", "floor")}
    assert [(w.gpu, w.display.x_display, w.display.fullscreen) for w in cave.walls] == [
        (0, ":0.0", True), (0, ":0.0", True), (1, ":0.1", True), (1, ":0.1", True)]


# Shipped at their projectors' resolution without a display table: a CAVE's geometry for
# the offline pictures and the render bench, too large for windows side by side on a desktop
AT_PROJECTOR_RESOLUTION = {"flex4_hd"}


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: p.stem)
def test_shipped_config_loads_with_normals_into_the_room(path):
    cave = load_cave(path)
    assert cave.name == path.stem
    projected = (any(w.display.fullscreen for w in cave.walls)  # for real projectors only
                 or path.stem in AT_PROJECTOR_RESOLUTION)
    for wall in cave.walls:
        assert projected or (wall.resolution[0] <= 1280 and wall.resolution[1] <= 480)
        to_centre = ROOM_CENTRE - wall.center
        assert np.dot(wall.normal, to_centre) > 0, wall.name
        np.testing.assert_allclose(np.linalg.norm(wall.normal), 1.0)


def _edge(a, b):
    return frozenset((tuple(a), tuple(b)))


def test_flex4_walls_share_edges_exactly():
    cave = load_cave(ROOT / DEFAULT_CAVE)
    front, left, right, floor = (cave.wall(n) for n in ("front", "left", "right", "floor"))
    # exact equality: the seams are the same floats on both walls
    assert np.array_equal(front.lower_left, left.lower_right)
    assert np.array_equal(front.upper_left, left.upper_right)
    assert np.array_equal(front.lower_right, right.lower_left)
    assert np.array_equal(front.upper_right, right.upper_left)
    assert np.array_equal(front.lower_left, floor.upper_left)
    assert np.array_equal(front.lower_right, floor.upper_right)
    assert np.array_equal(left.lower_left, floor.lower_left)
    assert np.array_equal(right.lower_right, floor.lower_right)
    for w in cave.walls:
        assert (w.width, w.height) == (3.0, 3.0)


def test_flex4_hd_is_flex4_at_16_by_10_projector_resolution():
    cave = load_cave(ROOT / "config/cave/flex4_hd.toml")
    assert cave.names == ("front", "left", "right", "floor")
    front, left, right, floor = cave.walls
    for wall in (front, left, right):
        assert (wall.width, wall.height, wall.resolution) == (3.6, 2.25, (1920, 1200))
    assert (floor.width, floor.height, floor.resolution) == (3.6, 3.6, (1200, 1200))
    assert np.array_equal(front.lower_left, left.lower_right)
    assert np.array_equal(front.lower_right, right.lower_left)
    assert np.array_equal(front.lower_left, floor.upper_left)
    assert np.array_equal(right.lower_right, floor.lower_right)


def test_six_sided_is_a_closed_cube():
    cave = load_cave(ROOT / "config/cave/six_sided.toml")
    assert set(cave.names) == {"front", "left", "right", "floor", "ceiling", "back"}
    count: dict[frozenset, int] = {}
    for w in cave.walls:
        c = w.corners
        for i in range(4):
            e = _edge(c[i], c[(i + 1) % 4])
            count[e] = count.get(e, 0) + 1
    assert len(count) == 12 and set(count.values()) == {2}


def test_power_wall_has_square_pixels():
    (wall,) = load_cave(ROOT / "config/cave/power_wall.toml").walls
    assert (wall.width, wall.height, wall.resolution) == (6.0, 2.25, (1280, 480))
    assert wall.lower_left[2] == 0.5
    np.testing.assert_allclose(wall.normal, [0.0, -1.0, 0.0])


def test_wall_derived_quantities():
    w = Wall("w", [0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 0.0, 1.0], (200, 100))
    np.testing.assert_array_equal(w.upper_right, [2.0, 0.0, 1.0])
    np.testing.assert_array_equal(w.right, [1.0, 0.0, 0.0])
    np.testing.assert_array_equal(w.up, [0.0, 0.0, 1.0])
    np.testing.assert_array_equal(w.normal, [0.0, -1.0, 0.0])
    np.testing.assert_array_equal(w.center, [1.0, 0.0, 0.5])
    np.testing.assert_array_equal(w.corners, [[0, 0, 0], [2, 0, 0], [2, 0, 1], [0, 0, 1]])
    assert (w.width, w.height) == (2.0, 1.0)
    assert w.lower_left.dtype == np.float64
    with pytest.raises(ValueError):
        w.lower_left[0] = 5.0  # read-only
    assert w == Wall("w", w.lower_left, w.lower_right, w.upper_left, (200, 100))
    assert hash(w) == hash(Wall("w", w.lower_left, w.lower_right, w.upper_left, (200, 100)))


def test_cave_wall_lookup():
    cave = load_cave(ROOT / DEFAULT_CAVE)
    assert cave.wall("floor").name == "floor"
    with pytest.raises(KeyError, match="front, left, right, floor"):
        cave.wall("ceiling")
    assert isinstance(cave, Cave) and isinstance(cave.walls, tuple)


def test_a_scaled_cave_keeps_its_geometry_and_its_sides_within_bounds():
    cave = load_cave(DEFAULT_CAVE)
    half, tiny, huge = cave.scaled(0.5), cave.scaled(0.001), cave.scaled(100.0)
    front = cave.wall("front")
    assert half.wall("front").resolution == tuple(round(n / 2) for n in front.resolution)
    assert np.array_equal(half.wall("front").corners, front.corners)
    assert half.names == cave.names and half.eye_separation == cave.eye_separation
    assert {n for w in tiny.walls for n in w.resolution} == {16}
    assert {n for w in huge.walls for n in w.resolution} == {8192}


def test_name_defaults_to_file_stem(tmp_path):
    cave = load_cave(write_cave(tmp_path / "my_room.toml", [FRONT]))
    assert cave.name == "my_room"


def test_upper_right_is_optional(tmp_path):
    wall = {k: v for k, v in FRONT.items() if k != "upper_right"}
    cave = load_cave(write_cave(tmp_path / "c.toml", [wall]))
    np.testing.assert_array_equal(cave.walls[0].upper_right, FRONT["upper_right"])


def test_gpu_is_optional_and_part_of_the_wall(tmp_path):
    cave = load_cave(write_cave(tmp_path / "c.toml", [dict(FRONT, gpu=0),
                                                      dict(FRONT, name="back", gpu=255)]))
    assert [w.gpu for w in cave.walls] == [0, 255]
    assert load_cave(write_cave(tmp_path / "d.toml", [FRONT])).walls[0].gpu is None
    front = cave.walls[0]
    other = Wall("front", front.lower_left, front.lower_right, front.upper_left, (480, 480), 1)
    assert front != other and hash(front) != hash(other)


def test_walls_naming_one_node_are_its_walls_and_the_others_are_their_own(tmp_path):
    walls = [dict(FRONT, node="ws1"), dict(FRONT, name="left", node="ws1"),
             dict(FRONT, name="right"), dict(FRONT, name="floor", node="ws1")]
    cave = load_cave(write_cave(tmp_path / "c.toml", walls))
    assert cave.nodes == {"ws1": ("front", "left", "floor"), "right": ("right",)}
    assert cave.wall("right").node == "right" and cave.wall("front").node == "ws1"
    assert load_cave(write_cave(tmp_path / "d.toml", [FRONT])).nodes == {"front": ("front",)}


@pytest.mark.parametrize(("walls", "key", "words"), [
    ([dict(FRONT, node="left"), dict(FRONT, name="left", node="ws2")], "wall[0].node",
     "'left' is the name of a wall that another node ('ws2') draws"),
    ([dict(FRONT, node="ws1", gpu=0), dict(FRONT, name="left", node="ws1", gpu=1)],
     "wall[1].gpu", "must be the gpu of every wall of node 'ws1': wall[0] has 0"),
    ([dict(FRONT, node="a b")], "wall[0].node", "letter, digit"),
])
def test_a_node_is_named_once_and_computes_on_one_gpu(tmp_path, walls, key, words):
    with pytest.raises(CaveError) as error:
        load_cave(write_cave(tmp_path / "c.toml", walls))
    assert key in str(error.value) and words in str(error.value)


def _front(**changes):
    w = dict(FRONT, **changes)
    return {k: v for k, v in w.items() if v is not None}


# (id, walls, top-level keys, dotted key named in the error, value named, extra words)
BAD = [
    ("not_rectangle", [_front(upper_left=[-1.4, 1.5, 3.0], upper_right=None)], {},
     "wall[0].upper_left", [-1.4, 1.5, 3.0], "rectangle"),
    ("zero_width", [_front(lower_right=[-1.5, 1.5, 0.0], upper_right=None)], {},
     "wall[0].lower_right", [-1.5, 1.5, 0.0], "area"),
    ("zero_height", [_front(upper_left=[-1.5, 1.5, 1e-7], upper_right=None)], {},
     "wall[0].upper_left", [-1.5, 1.5, 1e-7], "area"),
    ("duplicate_names", [FRONT, _front(resolution=[240, 240])], {},
     "wall[1].name", "front", "unique"),
    ("bad_upper_right", [_front(upper_right=[1.5, 1.5, 3.1])], {},
     "wall[0].upper_right", [1.5, 1.5, 3.1], "rectangle"),
    ("unknown_wall_key", [_front(colour="red")], {}, "wall[0].colour", "red", "unknown key"),
    ("unknown_top_key", [FRONT], {"screens": 4}, "screens", 4, "unknown key"),
    ("non_square_pixels", [_front(resolution=[640, 480])], {},
     "wall[0].resolution", [640, 480], "pixels must be square"),
    ("resolution_too_small", [_front(resolution=[8, 8])], {},
     "wall[0].resolution", [8, 8], ">= 16"),
    ("resolution_too_big", [_front(resolution=[9000, 9000])], {},
     "wall[0].resolution", [9000, 9000], "<= 8192"),
    ("resolution_float", [_front(resolution=[480.0, 480])], {},
     "wall[0].resolution", [480.0, 480], "integers"),
    ("resolution_three", [_front(resolution=[480, 480, 3])], {},
     "wall[0].resolution", [480, 480, 3], "2 integers"),
    ("nan_corner", [_front(lower_left=[math.nan, 1.5, 0.0])], {},
     "wall[0].lower_left", [math.nan, 1.5, 0.0], "finite"),
    ("inf_corner", [_front(upper_right=[math.inf, 1.5, 3.0])], {},
     "wall[0].upper_right", [math.inf, 1.5, 3.0], "finite"),
    ("string_corner", [_front(lower_left="origin")], {},
     "wall[0].lower_left", "origin", "3 finite numbers"),
    ("bool_corner", [_front(lower_left=[True, 1.5, 0.0])], {},
     "wall[0].lower_left", [True, 1.5, 0.0], "3 finite numbers"),
    ("two_numbers", [_front(upper_left=[-1.5, 3.0])], {},
     "wall[0].upper_left", [-1.5, 3.0], "3 finite numbers"),
    ("bad_wall_name", [_front(name="front wall")], {}, "wall[0].name", "front wall", "letter"),
    ("long_wall_name", [_front(name="w" * 33)], {}, "wall[0].name", "w" * 33, "1-32"),
    ("bad_cave_name", [FRONT], {"name": ""}, "name", "", "1-32"),
    ("gpu_negative", [_front(gpu=-1)], {}, "wall[0].gpu", -1, "integer >= 0"),
    ("gpu_too_big", [_front(gpu=256)], {}, "wall[0].gpu", 256, "<= 255"),
    ("gpu_float", [_front(gpu=1.0)], {}, "wall[0].gpu", 1.0, "EGL device index"),
    ("gpu_bool", [_front(gpu=True)], {}, "wall[0].gpu", True, "EGL device index"),
    ("gpu_string", [_front(gpu="0")], {}, "wall[0].gpu", "0", "cavesim doctor"),
]


@pytest.mark.parametrize("walls, top, key, value, words",
                         [b[1:] for b in BAD], ids=[b[0] for b in BAD])
def test_bad_geometry_is_refused_naming_file_key_and_value(tmp_path, walls, top, key, value,
                                                          words):
    path = write_cave(tmp_path / "bad.toml", walls, **top)
    with pytest.raises(CaveError) as err:
        load_cave(path)
    msg = str(err.value)
    assert msg.startswith(f"{path}: {key} = ")
    assert repr(value) in msg  # e.g. "[nan, 1.5, 0.0]"
    assert words in msg


def test_missing_key_is_named(tmp_path):
    path = write_cave(tmp_path / "c.toml", [_front(resolution=None)])
    with pytest.raises(CaveError, match=r"wall\[0\]\.resolution is missing"):
        load_cave(path)


def test_no_walls(tmp_path):
    path = write_cave(tmp_path / "c.toml", [], name="empty")
    with pytest.raises(CaveError, match="at least one"):
        load_cave(path)


def test_unreadable_and_invalid_files(tmp_path):
    with pytest.raises(CaveError, match="cannot read"):
        load_cave(tmp_path / "absent.toml")
    (tmp_path / "broken.toml").write_text("[[wall]\n")
    with pytest.raises(CaveError, match="not valid TOML"):
        load_cave(tmp_path / "broken.toml")


def test_parse_cave_from_dict_and_error_is_a_value_error():
    assert parse_cave({"wall": [FRONT]}).name == "cave"
    with pytest.raises(ValueError, match="<dict>: wall = 3"):
        parse_cave({"wall": 3})


def test_a_desktop_cave_keeps_the_walls_and_lays_their_windows_side_by_side():
    flex4 = load_cave(ROOT / "config" / "cave" / "flex4.toml")
    desktop = parse_cave(tomllib.loads(desktop_cave_file(flex4, ("front", "floor"), 64)))
    assert desktop.names == ("front", "floor")
    assert desktop.eye_separation == flex4.eye_separation
    for wall in desktop.walls:
        assert wall == dataclasses.replace(flex4.wall(wall.name), resolution=(64, 64),
                                           display=wall.display)
        assert not wall.display.vsync and wall.display.swap_lock
    windows = [w.display.window for w in desktop.walls]
    assert windows == [(0, 0, 64, 64), (64 + WINDOW_GAP, 0, 64, 64)]
