"""What each drawing technique adds: a wall drawn with every technique and again without
one, from the same particles and the same eye, at a frame of a scene where it shows.

TECHNIQUES is the one table of them: a name, what the technique adds to the picture, the
render settings that leave it out, and the frame of the brownout demo that shows it. The
docs show the sheet this module draws (`technique_sheet`) beside the same notes
(tests/docs holds the page to the table).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from PIL import Image, ImageDraw

from cavesim.core.cave.geometry import Wall
from cavesim.core.scene.model import Scene
from cavesim.core.tracking.scripted_head import ScriptedHead
from cavesim.gpu.engine import ParticleSystem
from cavesim.gpu.gl.context import create_context
from cavesim.gpu.render.wall_renderer import RenderSettings, WallRenderer
from cavesim.tools.reports.scene_pictures import FRAME_DT, SETTINGS, scene_inputs


@dataclass(frozen=True)
class Technique:
    name: str
    adds: str  # what the picture gains with it
    without: dict  # RenderSettings fields that leave it out
    frame: int  # of the brownout demo, where it shows


_FLAT_SKY = {"sky_zenith": SETTINGS.sky, "sun_radius": 0.0}
TECHNIQUES = (
    Technique("spreading parcels",
              "each particle stands for a puff of grains that the turbulence spreads as it "
              "ages (Taylor's puff, its whole extinction kept): puffs merge into one cloud",
              {"eddy_diffusivity": 0.0}, 330),
    Technique("shadows from the light map",
              "dust shadowed from the sun by the dust between: a lit top and a dark core",
              {"shadows": False}, 330),
    Technique("multiple scattering",
              "light scattered more than once (in octaves): the shadowed core is not black",
              {"multiple_scattering": False}, 330),
    Technique("backward lobe",
              "the phase function's second lobe: dust with the sun behind the viewer is not "
              "dull", {"backward_share": 0.0}, 480),
    Technique("soft particles",
              "dust fades into the ground over a distance: no hard line where a billboard "
              "cuts the terrain (faint in the demo's thin, spread dust)",
              {"soft_distance": 1e-4}, 480),
    Technique("sky gradient and sun",
              "a sky darker and bluer toward the zenith, and the sun's disc",
              _FLAT_SKY, 60),
    Technique("distance fog",
              "the ground fades into the horizon: a depth cue for far dust",
              {"fog_distance": 1e9}, 60),
)
LABEL_HEIGHT = 16  # px above each picture


def technique_pictures(scene: Scene, wall: Wall, settings: RenderSettings = SETTINGS
                       ) -> list[tuple[Technique, np.ndarray, np.ndarray]]:
    """For each of TECHNIQUES: `wall` at its frame of `scene`, from the scripted head,
    without it and with every technique ((height, width, 3) uint8 each)."""
    ctx = create_context()
    system = ParticleSystem(ctx, scene)
    by_frame = {t.frame: [u for u in TECHNIQUES if u.frame == t.frame] for t in TECHNIQUES}
    drawn = {}
    try:
        for k, (inputs, scene_frame) in enumerate(scene_inputs(scene, max(by_frame)), start=1):
            system.step(inputs, scene_frame)
            eye = ScriptedHead().at(k * FRAME_DT).position
            for technique in by_frame.get(k, ()):
                drawn[technique.name] = tuple(
                    _draw(ctx, system, wall, chosen, eye, scene_frame.helicopter)
                    for chosen in (replace(settings, **technique.without), settings))
    finally:
        system.release()
        ctx.release()
    return [(t, *drawn[t.name]) for t in TECHNIQUES]


def _draw(ctx, system, wall, settings, eye, helicopter) -> np.ndarray:
    renderer = WallRenderer(ctx, system, wall, settings)
    try:
        return renderer.render(eye, helicopter)
    finally:
        renderer.release()


def technique_sheet(pairs: list[tuple[Technique, np.ndarray, np.ndarray]],
                    pairs_per_row: int = 2) -> Image.Image:
    """The pairs in a grid, each picture under its label: without, then with."""
    height, width = pairs[0][1].shape[:2]
    rows = -(-len(pairs) // pairs_per_row)
    sheet = Image.new("RGB", (2 * pairs_per_row * width, rows * (height + LABEL_HEIGHT)),
                      "white")
    draw = ImageDraw.Draw(sheet)
    for index, (technique, without, with_) in enumerate(pairs):
        y = index // pairs_per_row * (height + LABEL_HEIGHT)
        for side, (label, picture) in enumerate(((f"without {technique.name}", without),
                                                 (f"with it (frame {technique.frame})", with_))):
            x = (index % pairs_per_row * 2 + side) * width
            draw.text((x + 4, y + 2), label, fill="black")
            sheet.paste(Image.fromarray(picture), (x, y + LABEL_HEIGHT))
    return sheet
