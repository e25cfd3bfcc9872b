"""Seams in real pictures: dust across a shared edge looks the same on both walls.

Each wall draws the dust with its own off-axis frustum; shading, size and density must
still depend only on the world and the one tracked eye, or the cloud breaks at the edges.
Checked on the default CAVE and on one whose walls meet at 120 degrees.
"""

import tomllib
from pathlib import Path

import numpy as np
import pytest
from render_helpers import (
    angled_cave,
    edge_lines,
    edge_samples,
    particles_at,
    seam_jumps,
    shared_edges,
)
from scenes import make_scene

from cavesim.core.cave.geometry import parse_cave
from cavesim.gpu.engine import ParticleSystem
from cavesim.gpu.render.wall_renderer import RenderSettings, WallRenderer

FLEX4 = Path(__file__).parents[2] / "config" / "cave" / "flex4.toml"
EYE = np.array([0.45, -0.35, 1.5])  # off centre: each edge is seen at other angles per wall
NEAR_CORNER = np.array([1.0, 0.9, 2.2])  # seen from here, the front and right walls graze
PLANE = {"kind": "plane", "friction": 0.3, "resilience": 0.4}
MAX_JUMP = 1.5  # times the step between neighbouring pixel lines inside a wall


def flex4(side_px: int):
    """The default CAVE, config/cave/flex4.toml, at a test resolution."""
    data = tomllib.loads(FLEX4.read_text())
    for wall in data["wall"]:
        wall["resolution"] = [side_px, side_px]
    return parse_cave(data)


CAVES = pytest.mark.parametrize("make_cave", [flex4, angled_cave], ids=["flex4", "angled_120"])


def edge_cloud(cave, eye, per_edge: int, seed: int = 0) -> np.ndarray:
    """Dense dust on rays from `eye` through every shared edge, from inside the room to far
    beyond it (where billboards reach their minimum size in pixels), half of it low over
    the ground so the soft edges take part, and some all around the eye, whose discs
    reach over several walls; both particle classes."""
    rng = np.random.default_rng(seed)
    around = rng.normal(0, 1, (per_edge // 10, 3))
    around *= rng.uniform(0.1, 0.5, (len(around), 1)) / np.linalg.norm(around, axis=1)[:, None]
    clouds = [eye + around]
    for _, _, edge in shared_edges(cave):
        on_edge = edge[0] + np.outer(rng.uniform(0, 1, per_edge), edge[1] - edge[0])
        reach = np.exp(rng.uniform(np.log(0.7), np.log(20.0), (per_edge, 1)))
        points = eye + reach * (on_edge - eye + rng.normal(0, 0.1, (per_edge, 3)))
        points[::2, 2] = rng.uniform(0.0, 0.4, per_edge - per_edge // 2)
        clouds.append(points)
    records = particles_at(np.concatenate(clouds))
    records["class_id"] = np.arange(len(records)) % 2
    return records


CLOUD_DENSITY = 1.5  # per parcel: the clouds', whatever the demo's look is tuned to


def pictures(ctx, cave, records, eye=EYE, ground=True, **settings):
    """Every wall's picture of `records` from `eye`, over a ground plane or only the sky."""
    settings = {"density_per_particle": CLOUD_DENSITY, **settings}
    scene = make_scene(drag=False, collision=PLANE if ground else None, capacity=len(records))
    system = ParticleSystem(ctx, scene)
    system.write_particles(records)
    return {w.name: WallRenderer(ctx, system, w, RenderSettings(**settings)).render(eye, None)
            for w in cave.walls}


@CAVES
@pytest.mark.parametrize("eye", [EYE, NEAR_CORNER], ids=["off_centre", "near_a_corner"])
def test_a_dense_cloud_is_as_bright_on_both_sides_of_every_edge(ctx, make_cave, eye):
    cave = make_cave(128)
    jumps = seam_jumps(cave, pictures(ctx, cave, edge_cloud(cave, eye, per_edge=4000), eye))
    assert len(jumps) == {"flex4": 5, "angled": 3}[cave.name]
    assert max(jumps.values()) < MAX_JUMP, jumps


def test_the_seam_measure_sees_a_wall_drawn_a_tenth_darker(ctx):
    cave = flex4(128)
    images = pictures(ctx, cave, edge_cloud(cave, EYE, per_edge=4000))
    images["right"] = (images["right"] * 0.9).astype(np.uint8)
    jumps = seam_jumps(cave, images)
    assert jumps["front", "right"] > MAX_JUMP, jumps


@CAVES
def test_dust_on_an_edge_has_one_profile_on_both_walls(ctx, make_cave):
    """Lone particles on rays through each edge, far enough to be drawn at the minimum
    size (thinned to keep their optical depth): at every point along the edge the step
    across it is no larger than the steps beside it inside either wall, so position, size
    and brightness do not depend on the wall."""
    cave = make_cave(240)
    points = [EYE + reach * (edge[0] + t * (edge[1] - edge[0]) - EYE)
              for _, _, edge in shared_edges(cave)
              for t, reach in zip(np.linspace(0.1, 0.9, 7), np.geomspace(3, 20, 7), strict=True)]
    images = pictures(ctx, cave, particles_at(points), ground=False, min_radius_pixels=6.0,
                      density_per_particle=1.0)
    sky = np.array(RenderSettings().sky) * 255
    for a, b, edge in shared_edges(cave):
        count = edge_samples(edge, (a, images[a.name]), (b, images[b.name]))
        (outer_a, inner_a), (outer_b, inner_b) = (edge_lines(w, images[w.name], edge, count)
                                                  for w in (a, b))
        contrast = np.abs(outer_a - sky).max()
        assert contrast > 20, f"{a.name}|{b.name}: no dust on the edge"
        excess = np.abs(outer_a - outer_b) - np.maximum(np.abs(outer_a - inner_a),
                                                        np.abs(outer_b - inner_b))
        assert excess.max() <= 0.1 * contrast, f"{a.name}|{b.name}"
