"""The unfolded-CAVE composite and the run animation, on walls built in code (no GL).

Edge continuity is checked by painting every wall with its own room coordinates (x, y, z
as R, G, B) and requiring that pixels on both sides of each join in the composite show
the same room point, within a pixel.
"""

from __future__ import annotations

import importlib.util
import logging
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from cavesim.core.cave.geometry import Cave, Wall
from cavesim.gpu.render import compose, compose_run, unfold_layout, write_animation
from cavesim.gpu.render.animation import MAX_WIDTH_PX

PPM = 16  # pixels per metre of every test wall: small pictures, whole-pixel edges


def wall(name, lower_left, lower_right, upper_left, turns=0):
    """A wall from three corners seen from inside; `turns` quarter turns of its picture
    (clockwise, keeping the normal) so the composite has to turn it back."""
    ll, lr, ul = (np.array(p, float) for p in (lower_left, lower_right, upper_left))
    for _ in range(turns % 4):
        ll, lr, ul = lr, lr + ul - ll, ll
    width, height = np.linalg.norm(lr - ll), np.linalg.norm(ul - ll)
    return Wall(name, ll, lr, ul, (round(width * PPM), round(height * PPM)))


def room(width=3.0, depth=3.0, height=3.0, sides=4, turns=0):
    """A box room centred on x = y = 0 with the given walls, like config/cave/*.toml;
    every wall but the front is turned by `turns`."""
    x, y, z = width / 2, depth / 2, height
    walls = [
        wall("front", (-x, y, 0), (x, y, 0), (-x, y, z)),
        wall("left", (-x, -y, 0), (-x, y, 0), (-x, -y, z), turns),
        wall("right", (x, y, 0), (x, -y, 0), (x, y, z), turns),
        wall("floor", (-x, -y, 0), (x, -y, 0), (-x, y, 0), turns),
        wall("ceiling", (-x, y, z), (x, y, z), (-x, -y, z), turns),
        wall("back", (x, -y, 0), (-x, -y, 0), (x, -y, z), turns),
    ]
    return Cave(f"box{sides}", tuple(walls[:sides]))


def power_wall():
    return Cave("power_wall", (wall("front", (-3, 3, 0.5), (3, 3, 0.5), (-3, 3, 2.75)),))


CAVES = {
    "flex": lambda: room(sides=4),
    "six_sided": lambda: room(sides=6),
    "flex_oblong": lambda: room(width=4, depth=2, height=2.5, sides=4),
    "six_sided_oblong": lambda: room(width=4, depth=2, height=2.5, sides=6),
    "six_sided_turned_1": lambda: room(sides=6, turns=1),
    "six_sided_turned_2": lambda: room(width=4, depth=2, height=2.5, sides=6, turns=2),
    "flex_turned_3": lambda: room(width=4, depth=2, height=2.5, sides=4, turns=3),
}


def rects(cave):
    """{wall: (x0, y0, x1, y1)} of each wall's pixels in the composite."""
    out = {}
    for name, (x, y, turns) in unfold_layout(cave).items():
        w = cave.wall(name)
        size = (round(w.width * PPM), round(w.height * PPM))
        width, height = size[::-1] if turns % 2 else size
        out[name] = (x, y, x + width, y + height)
    return out


def bounds(cave):
    corners = np.concatenate([w.corners for w in cave.walls])
    return corners.min(axis=0), corners.max(axis=0)


def paint(cave, w):
    """`w`'s picture with each pixel's room point (x, y, z) as RGB over the cave's box."""
    lo, hi = bounds(cave)
    cols, rows = w.resolution
    a = (np.arange(cols) + 0.5) / cols * w.width
    b = w.height - (np.arange(rows) + 0.5) / rows * w.height  # row 0 is the upper edge
    points = w.lower_left + a[None, :, None] * w.right + b[:, None, None] * w.up
    return np.rint((points - lo) / np.maximum(hi - lo, 1e-9) * 255).astype(np.uint8)


def decode(cave, rgb):
    lo, hi = bounds(cave)
    return lo + np.asarray(rgb, float) / 255 * (hi - lo)


def joins(rs):
    """Pairs of walls whose rectangles touch along a segment, each with the pixel
    coordinates just inside either side: [(a, b, pixels_in_a, pixels_in_b)]."""
    out = []
    names = list(rs)
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            for p, q in ((a, b), (b, a)):
                (px0, py0, px1, py1), (qx0, qy0, qx1, qy1) = rs[p], rs[q]
                lo, hi = max(py0, qy0), min(py1, qy1)
                if px1 == qx0 and hi > lo:  # p left of q
                    ys = np.arange(lo, hi)
                    out.append((p, q, (ys, np.full_like(ys, px1 - 1)), (ys, np.full_like(ys, qx0))))
                lo, hi = max(px0, qx0), min(px1, qx1)
                if py1 == qy0 and hi > lo:  # p above q
                    xs = np.arange(lo, hi)
                    out.append((p, q, (np.full_like(xs, py1 - 1), xs), (np.full_like(xs, qy0), xs)))
    return out


@pytest.mark.parametrize("kind", CAVES)
def test_layout_is_a_cross_around_the_front(kind):
    cave = CAVES[kind]()
    rs = rects(cave)
    names = list(rs)
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            (ax0, ay0, ax1, ay1), (bx0, by0, bx1, by1) = rs[a], rs[b]
            assert min(ax1, bx1) <= max(ax0, bx0) or min(ay1, by1) <= max(ay0, by0), (a, b)
    fx0, fy0, fx1, fy1 = rs["front"]
    assert unfold_layout(cave)["front"][2] == 0
    assert rs["left"][2] == fx0 and rs["left"][1] == fy0 and rs["left"][3] == fy1
    assert rs["right"][0] == fx1 and rs["right"][1] == fy0 and rs["right"][3] == fy1
    assert rs["floor"][:3] == (fx0, fy1, fx1)
    if "ceiling" in rs:
        assert rs["ceiling"][0] == fx0 and rs["ceiling"][2:] == (fx1, fy0)
        assert rs["back"][0] == rs["right"][2] and rs["back"][1] == fy0
    # as small as possible: the composite is the bounding box of the walls, from (0, 0)
    assert min(r[0] for r in rs.values()) == 0 and min(r[1] for r in rs.values()) == 0
    image = compose(cave, {})
    assert image.size == (max(r[2] for r in rs.values()), max(r[3] for r in rs.values()))


@pytest.mark.parametrize("kind", CAVES)
def test_room_points_continue_across_every_join(kind):
    cave = CAVES[kind]()
    composite = np.asarray(compose(cave, {w.name: paint(cave, w) for w in cave.walls}))
    found = set()
    quantum = np.linalg.norm(bounds(cave)[1] - bounds(cave)[0]) / 255
    for a, b, in_a, in_b in joins(rects(cave)):
        pa, pb = decode(cave, composite[in_a]), decode(cave, composite[in_b])
        # pixel centres half a pixel either side of a folded edge are 0.71 px apart
        gap = np.linalg.norm(pa - pb, axis=1)
        assert gap.max() <= 1.0 / PPM + quantum, (a, b, gap.max())
        found.add(frozenset((a, b)))
    expected = {frozenset(("front", n)) for n in ("left", "right", "floor", "ceiling")}
    expected.add(frozenset(("right", "back")))
    assert found >= {j for j in expected if j <= set(cave.names)}


def test_a_turned_wall_is_turned_back():
    assert unfold_layout(room(sides=6, turns=1))["floor"][2] % 4 != 0
    assert {t for _, _, t in unfold_layout(room(sides=6)).values()} == {0}


def test_a_power_wall_is_itself():
    cave = power_wall()
    assert unfold_layout(cave) == {"front": (0, 0, 0)}
    picture = paint(cave, cave.walls[0])
    assert np.array_equal(np.asarray(compose(cave, {"front": picture})), picture)


def test_compose_resizes_and_leaves_missing_walls_background():
    cave = room(sides=4)
    rs = rects(cave)
    big = np.full((200, 300, 3), (250, 10, 10), np.uint8)  # not the front's 48 x 48
    image = np.asarray(compose(cave, {"front": big}, background=(1, 2, 3)))
    x0, y0, x1, y1 = rs["front"]
    assert (image[y0:y1, x0:x1] == (250, 10, 10)).all()
    x0, y0, x1, y1 = rs["floor"]
    assert (image[y0:y1, x0:x1] == (1, 2, 3)).all()
    with pytest.raises(ValueError, match="unknown walls"):
        compose(cave, {"window": big})
    with pytest.raises(ValueError, match="shape"):
        compose(cave, {"front": np.zeros((4, 4, 2), np.uint8)})


def write_frames(cave, walls_dir: Path, frames: dict[str, list[int]]) -> None:
    for w in cave.walls:
        (walls_dir / w.name).mkdir(parents=True)
        for n in frames[w.name]:
            shade = np.full((w.resolution[1], w.resolution[0], 3), n * 40, np.uint8)
            Image.fromarray(shade).save(walls_dir / w.name / f"frame_{n:06d}.png")


def test_compose_run_writes_only_frames_every_wall_has(tmp_path, caplog):
    cave = room(sides=4)
    frames = {w.name: [0, 1, 2, 3] for w in cave.walls}
    frames["left"] = [0, 1, 3]
    frames["floor"] = [0, 1, 2, 3, 5]
    write_frames(cave, tmp_path / "walls", frames)
    (tmp_path / "walls" / "front" / "notes.txt").write_text("not a frame")
    with caplog.at_level(logging.WARNING, logger="cavesim.gpu.render.composite"):
        paths = compose_run(cave, tmp_path / "walls", tmp_path / "out")
    assert [p.name for p in paths] == [f"composite_{n:06d}.png" for n in (0, 1, 3)]
    assert "left lacks 2, 5" in caplog.text and "floor lacks" not in caplog.text
    x0, y0, _, _ = rects(cave)["front"]
    with Image.open(paths[-1]) as im:
        assert im.size == compose(cave, {}).size
        assert im.getpixel((x0, y0)) == (120, 120, 120)


def test_compose_run_needs_the_walls_dir(tmp_path):
    with pytest.raises(FileNotFoundError, match="walls_dir"):
        compose_run(room(sides=4), tmp_path / "nowhere", tmp_path / "out")


def numbered_frames(tmp_path, count, size=(40, 30)):
    paths = []
    for n in range(count):
        path = tmp_path / f"composite_{n:06d}.png"
        Image.new("RGB", size, (60 * n, 255 - 60 * n, 90)).save(path)
        paths.append(path)
    return paths


def test_write_animation_makes_a_looping_gif(tmp_path):
    path = write_animation(numbered_frames(tmp_path, 4), tmp_path / "run.gif", fps=10)
    with Image.open(path) as im:
        assert im.format == "GIF" and im.n_frames == 4
        assert im.info["loop"] == 0 and im.info["duration"] == 100
        assert im.size == (40, 30)


def test_write_animation_scales_wide_frames_down(tmp_path):
    frames = numbered_frames(tmp_path, 2, size=(2 * MAX_WIDTH_PX, 100))
    with Image.open(write_animation(frames, tmp_path / "run.gif")) as im:
        assert im.size == (MAX_WIDTH_PX, 50) and im.n_frames == 2


def test_write_animation_rejects_bad_input(tmp_path):
    with pytest.raises(ValueError, match="empty"):
        write_animation([], tmp_path / "run.gif")
    frames = numbered_frames(tmp_path, 2)
    with pytest.raises(ValueError, match="fps"):
        write_animation(frames, tmp_path / "run.gif", fps=0)
    with pytest.raises(ValueError, match=".gif, .mp4"):
        write_animation(frames, tmp_path / "run.avi")


def test_mp4_without_imageio_ffmpeg_says_what_to_do(tmp_path, monkeypatch):
    find_spec = importlib.util.find_spec  # as on a machine without the package
    monkeypatch.setattr(importlib.util, "find_spec",
                        lambda name, *rest: None if name == "imageio_ffmpeg"
                        else find_spec(name, *rest))
    with pytest.raises(ImportError, match="imageio-ffmpeg.*gif"):
        write_animation(numbered_frames(tmp_path, 2), tmp_path / "run.mp4")
