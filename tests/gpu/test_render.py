"""Wall rendering: seams, the hash untouched, identical pixels, non-blank, goldens."""

import hashlib
import multiprocessing
from concurrent.futures import ProcessPoolExecutor

import numpy as np
import pytest
from PIL import Image
from render_helpers import GOLDEN, assert_matches_golden, particles_at, small_cave
from scenes import FOUNTAIN, make_scene, particle_cloud, scene_dict

from cavesim.core.random_texture import draw_transform
from cavesim.core.scene_frame import HelicopterPose
from cavesim.gpu.engine import FrameInput, ParticleSystem
from cavesim.gpu.render.light_map import LightMap
from cavesim.gpu.render.text import TextLine
from cavesim.gpu.render.wall_renderer import WallRenderer

EYE = np.array([0.2, -0.3, 1.6])
HELICOPTER = HelicopterPose((0.0, 9.0, 5.0), -np.pi / 2, 0.4)
PLANE = {"kind": "plane", "friction": 0.3, "resilience": 0.4}


def blob_heights(column: np.ndarray, clear: np.ndarray) -> list[float]:
    """Vertical centroids (px from the top) of the dust blobs along one pixel column, found
    against the same column drawn without dust."""
    weight = np.abs(column.astype(float) - clear).sum(axis=1)
    weight[weight < 6] = 0
    rows = np.arange(len(weight))
    edges = np.flatnonzero(np.diff(np.r_[0, (weight > 0).astype(int), 0]))
    return [float((rows[a:b] * weight[a:b]).sum() / weight[a:b].sum())
            for a, b in zip(edges[::2], edges[1::2], strict=True)]


def test_a_cloud_on_the_seam_meets_itself_on_both_walls(ctx):
    """Particles on rays through the front/left edge: same heights on both sides."""
    cave = small_cave(resolution=(480, 480))
    edge = [np.array([-1.5, 1.5, z]) for z in (0.5, 1.1, 1.7, 2.3, 2.8)]
    points = [EYE + 1.3 * (e - EYE) for e in edge]
    system = ParticleSystem(ctx, make_scene(drag=False, capacity=100))
    system.write_particles(particles_at(points))
    front, left = (WallRenderer(ctx, system, cave.wall(name)) for name in ("front", "left"))
    pictures = front.render(EYE, None), left.render(EYE, None)
    system.write_particles(particle_cloud(0))
    clear = front.render(EYE, None), left.render(EYE, None)
    front_heights = blob_heights(pictures[0][:, 0], clear[0][:, 0])
    left_heights = blob_heights(pictures[1][:, -1], clear[1][:, -1])
    assert len(front_heights) == len(edge) == len(left_heights)
    np.testing.assert_allclose(front_heights, left_heights, atol=1.0)


def test_rendering_leaves_the_checksum_alone(ctx):
    system = ParticleSystem(ctx, make_scene(emitters=[FOUNTAIN], collision=PLANE))
    rng = np.random.default_rng(1)
    for _ in range(20):
        system.step(FrameInput(1 / 60, draw_transform(rng, 64)))
    before = system.checksum()
    renderer = WallRenderer(ctx, system, small_cave().wall("front"))
    renderer.render(EYE, HELICOPTER)
    assert system.checksum() == before
    system.step(FrameInput(1 / 60, draw_transform(rng, 64)))  # the engine still steps
    assert system.live_count > before.particles


def test_pictures_show_dust_helicopter_and_ground(ctx):
    system = ParticleSystem(ctx, make_scene(collision=PLANE, capacity=3000))
    system.write_particles(particle_cloud(3000, box=((-1, 3, 0.5), (1, 6, 3))))
    renderer = WallRenderer(ctx, system, small_cave().wall("front"))
    full = renderer.render(EYE, HELICOPTER).astype(int)
    no_helicopter = renderer.render(EYE, None).astype(int)
    system.write_particles(particle_cloud(0))
    no_dust = renderer.render(EYE, HELICOPTER).astype(int)
    upper = np.s_[10:40]  # sky above the horizon, in front of the cloud
    assert (np.abs(full[upper] - no_dust[upper]).max(axis=2) > 3).mean() > 0.05, \
        "dust against the sky"
    assert (np.abs(full - no_dust).max(axis=2) > 10).mean() > 0.05, "dust is drawn"
    assert (np.abs(full - no_helicopter).max(axis=2) > 10).sum() > 20, "helicopter is drawn"
    ground = no_dust[-10:].mean(axis=(0, 1))
    assert ground[0] > ground[2] + 30, "sandy ground at the bottom of the front wall"


def test_same_state_same_pixels_and_golden(ctx):
    scene = make_scene(emitters=[FOUNTAIN], collision=PLANE, seed=3)
    system = ParticleSystem(ctx, scene)
    rng = np.random.default_rng(5)
    for _ in range(30):
        system.step(FrameInput(1 / 60, draw_transform(rng, 64)))
    renderer = WallRenderer(ctx, system, small_cave().wall("front"))
    first = renderer.render(EYE, HELICOPTER)
    assert np.array_equal(first, renderer.render(EYE, HELICOPTER))
    assert_matches_golden(first, "front_fountain_96", ctx.info["GL_RENDERER"])
    floor = WallRenderer(ctx, system, small_cave().wall("floor")).render(EYE, HELICOPTER)
    assert_matches_golden(floor, "floor_fountain_96", ctx.info["GL_RENDERER"])


def render_in_a_process(frames: int) -> str:
    """A fresh process: step the fountain scene and hash the front wall's pixels."""
    from cavesim.core.scene import parse_scene
    from cavesim.gpu.gl.context import create_context

    ctx = create_context()
    scene = parse_scene(scene_dict(emitters=[FOUNTAIN], collision=PLANE, seed=3), name="t")
    system = ParticleSystem(ctx, scene)
    rng = np.random.default_rng(5)
    for _ in range(frames):
        system.step(FrameInput(1 / 60, draw_transform(rng, 64)))
    pixels = WallRenderer(ctx, system, small_cave().wall("front")).render(EYE, HELICOPTER)
    return hashlib.sha256(pixels.tobytes()).hexdigest()


@pytest.mark.slow
def test_two_processes_draw_identical_pixels():
    with ProcessPoolExecutor(2, mp_context=multiprocessing.get_context("spawn")) as pool:
        a, b = pool.map(render_in_a_process, [40, 40])
    assert a == b


def test_golden_comparison_on_another_driver_still_catches_a_wrong_picture(monkeypatch):
    monkeypatch.delenv("CAVESIM_UPDATE_GOLDEN", raising=False)  # it must not save its fakes
    golden = np.asarray(Image.open(GOLDEN / "front_fountain_96.png").convert("RGB"))
    moved_edges = golden.copy()  # 2% of the pixels off by 60 levels: edges a pixel over
    rows, columns = np.unravel_index(np.random.default_rng(0).choice(
        golden.shape[0] * golden.shape[1], golden.shape[0] * golden.shape[1] // 50,
        replace=False), golden.shape[:2])
    moved_edges[rows, columns] = np.clip(golden[rows, columns].astype(int) + 60, 0, 255)
    assert_matches_golden(moved_edges, "front_fountain_96", "NVIDIA H100")
    with pytest.raises(AssertionError, match="pixels differ"):
        assert_matches_golden(moved_edges, "front_fountain_96", "llvmpipe (LLVM 15.0.6)")
    with pytest.raises(AssertionError, match="pixels differ"):
        assert_matches_golden(np.zeros_like(golden), "front_fountain_96", "NVIDIA H100")


def test_a_text_line_blends_white_glyphs_on_a_dark_band_and_nothing_else(ctx):
    """The preview's help line: drawn over what the window shows, only in its own band."""
    line = TextLine(ctx, "P pause")
    target = ctx.simple_framebuffer((160, 40), components=3)
    target.use()
    target.clear(0.0, 0.0, 1.0)
    line.draw(target.size, (4, 4))
    pixels = np.frombuffer(target.read(components=3), np.uint8).reshape(40, 160, 3)  # row 0 low
    width, height = line.size
    band = pixels[4:4 + height, 4:4 + width]
    outside = np.ones(pixels.shape[:2], bool)
    outside[4:4 + height, 4:4 + width] = False
    assert (pixels[outside] == (0, 0, 255)).all()
    assert band[..., 2].max() == 255 and band[..., 0].max() >= 250  # white ink
    assert band[..., 0].min() == 0 and band[..., 2].min() < 110  # the band darkens blue
    target.release()
    line.texture.release()


def test_the_walls_of_one_system_share_one_light_map_splatted_once_per_state(ctx, monkeypatch):
    splats = []
    original = LightMap.splat
    monkeypatch.setattr(LightMap, "splat", lambda self: (splats.append(self), original(self)))
    system = ParticleSystem(ctx, make_scene(drag=False, capacity=100))
    system.write_particles(particles_at([(0.0, 4.0 + 0.1 * k, 1.5) for k in range(20)]))
    cave = small_cave()
    front, left = (WallRenderer(ctx, system, cave.wall(name)) for name in ("front", "left"))
    try:
        assert front.light_map is left.light_map
        for renderer in (front, left, front):  # a second eye of the front wall
            renderer.render(EYE, None)
        assert splats == [front.light_map]
        system.step(FrameInput(1 / 60, draw_transform(np.random.default_rng(0), 64)))
        left.render(EYE, None)
        front.render(EYE, None)
        assert len(splats) == 2
    finally:
        shared = front.light_map
        front.release()
        left.release()
    again = WallRenderer(ctx, system, cave.wall("front"))
    assert again.light_map is not shared  # the last share freed the map
    again.release()
    system.release()
