"""The helicopter the walls draw: the built-in body with its tail rotor spinning as a
blurred disc, or the model a scene names in place of it."""

import numpy as np
import pygltflib
from gltf_files import cube, write_gltf
from render_helpers import small_cave
from scenes import scene_dict

from cavesim.core.scene import parse_scene
from cavesim.core.scene_frame import HelicopterPose
from cavesim.gpu.engine import ParticleSystem
from cavesim.gpu.render.meshes import built_in_helicopter
from cavesim.gpu.render.wall_renderer import WallRenderer

EYE = np.array([0.0, 0.0, 1.5])
SIZE = 96  # pixels a side of the front wall: 3 m at y = 1.5 m
QUARTER_TURN = np.pi / 2  # the four-bladed main rotor looks the same; the tail rotor's
# two blades, geared about five times faster, do not


def front(ctx, model=None) -> WallRenderer:
    """The front wall's renderer for a scene with a helicopter: its model file or none."""
    data = scene_dict(drag=False, capacity=10)
    data["helicopter"] = {"mass": 1000.0, "rotor_radius": 5.0, "hub_height": 1.3,
                          **({} if model is None else {"model": str(model)})}
    system = ParticleSystem(ctx, parse_scene(data, name="test"))
    return WallRenderer(ctx, system, small_cave(resolution=(SIZE, SIZE)).wall("front"))


def pixel_of(point) -> np.ndarray:
    """(row, column) where the ray from EYE through a world point crosses the front wall."""
    on_wall = EYE + (point - EYE) * (1.5 - EYE[1]) / (point[1] - EYE[1])
    return np.array([(3.0 - on_wall[2]) / 3.0 * SIZE - 0.5, (on_wall[0] + 1.5) / 3.0 * SIZE - 0.5])


def test_the_tail_rotor_spins_where_it_stands_and_nothing_else_moves(ctx):
    """The tail rotor's hub 2.2 m ahead at eye height, its near side toward the eye (the
    nose along -x): a quarter turn of the main rotor turns the tail rotor's disc only."""
    tail_rotor = built_in_helicopter().tail_rotor
    hub = np.array([0.0, 2.2, EYE[2]])
    pose = HelicopterPose(tuple(hub + np.array(tail_rotor.hub) * [1, 1, -1]), np.pi, 0.3)
    renderer = front(ctx)
    still = renderer.render(EYE, pose).astype(int)
    turned = renderer.render(EYE, HelicopterPose(pose.position, pose.yaw,
                                                 pose.rotor_angle + QUARTER_TURN)).astype(int)
    moved = np.abs(turned - still).max(axis=2)
    rows, columns = np.indices(moved.shape)
    radius_px = tail_rotor.radius * 1.5 / hub[1] * SIZE / 3.0
    centre = pixel_of(hub)
    on_disc = np.hypot(rows - centre[0], columns - centre[1]) <= radius_px + 1.5
    assert (moved[on_disc] > 12).sum() >= 8, f"the disc's blades moved: {moved.max()}"
    assert moved[~on_disc].max() <= 2, np.argwhere(moved > 2)


def test_a_scene_naming_a_model_draws_it_in_place_of_the_built_in_body(ctx, tmp_path):
    """A red 2 m box standing 4 m ahead: red where it stands, and no tail rotor (the file
    has no node for one); the built-in body drawn there is not red."""
    box = write_gltf(tmp_path / "box.glb", [cube((0.0, 1.0, 0.0), (2.0, 2.0, 2.0))],
                     [pygltflib.Node(mesh=0)])
    pose = HelicopterPose((0.0, 4.0, 0.0), 0.0, 0.3)
    turned = HelicopterPose(pose.position, pose.yaw, pose.rotor_angle + QUARTER_TURN)
    model, built_in = front(ctx, box), front(ctx)
    drawn = model.render(EYE, pose).astype(int)
    row, column = np.round(pixel_of(np.array([0.0, 3.0, 1.0]))).astype(int)  # its near face
    red = drawn[..., 0] - drawn[..., 1:].max(axis=2) > 60
    assert red[row - 4:row + 5, column - 4:column + 5].all(), drawn[row, column]
    assert np.abs(model.render(EYE, turned).astype(int) - drawn).max() <= 2
    body = built_in.render(EYE, pose).astype(int)
    assert not (body[..., 0] - body[..., 1:].max(axis=2) > 60).any()
    assert (np.abs(body - built_in.render(EYE, None)).max(axis=2) > 40).sum() > 100, \
        "the built-in body is drawn"
