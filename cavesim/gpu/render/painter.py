"""Pictures of walls: rendered from the frame's head pose, saved as PNG.

A wall node draws after it has reported the frame, and `cavesim render` after it has
checked the frame against its log; drawing only reads the particle stream, so it can
neither delay the checksum nor change it. Several walls are drawn from the one particle
state that was stepped.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import moderngl
from PIL import Image

from cavesim.core.cave.geometry import Cave
from cavesim.core.cave.projection import eye_positions
from cavesim.core.output import writing
from cavesim.core.scene_frame import SceneFrame
from cavesim.core.wire import FrameMessage
from cavesim.gpu.engine import ParticleSystem
from cavesim.gpu.render.wall_renderer import WallRenderer


class WallPainter:
    """Draws `walls` of `cave` into images/<wall>/frame_<k>.png (both eyes with stereo)."""

    def __init__(self, ctx: moderngl.Context, system: ParticleSystem, cave: Cave,
                 walls: Sequence[str], images: Path, stereo: bool = False) -> None:
        if unknown := [w for w in walls if w not in cave.names]:
            raise ValueError(f"wall {unknown[0]!r} is not in CAVE {cave.name!r}: it has "
                             f"{', '.join(cave.names)}")
        self.renderers = {w: WallRenderer(ctx, system, cave.wall(w)) for w in walls}
        self.eye_separation = cave.eye_separation
        self.images = Path(images)
        for wall in self.renderers:
            (self.images / wall).mkdir(parents=True, exist_ok=True)
        self.stereo = stereo

    def paint(self, k: int, message: FrameMessage, scene: SceneFrame) -> list[Path]:
        """Render frame k of each wall for each eye; the left (or only) eye is
        <wall>/frame_<k>.png."""
        eyes = eye_positions(message.head.position, message.head.orientation,
                             self.eye_separation, self.stereo)
        helicopter = scene.helicopter
        written = []
        for wall, renderer in self.renderers.items():
            for eye, position in eyes.items():
                suffix = "_right" if eye == "right" else ""
                path = self.images / wall / f"frame_{k:06d}{suffix}.png"
                picture = Image.fromarray(renderer.render(position, helicopter))
                with writing(path):
                    picture.save(path, compress_level=1)
                written.append(path)
        return written
