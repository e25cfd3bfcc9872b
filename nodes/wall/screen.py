"""What a node shows live: its walls in a window, side by side as its viewports
(`WallScreen`), or every wall of the CAVE unfolded in one desktop window (`PreviewScreen`,
`cavesim run --preview`).

Both draw with the renderer the headless PNGs use and present its picture into the
window's back buffer; the node decides when to swap (at once, or on the master's SWAP).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
from PIL import Image

from cavesim.core.cave.geometry import Cave, StereoMode, Wall
from cavesim.core.cave.projection import eye_positions
from cavesim.core.output import writing
from cavesim.core.scene_frame import SceneFrame
from cavesim.core.wire import FrameMessage
from cavesim.core.wire.payloads.from_nodes import Phase
from cavesim.gpu.engine import ParticleSystem
from cavesim.gpu.render.composite import compose
from cavesim.gpu.render.text import TextLine
from cavesim.gpu.render.unfold import slots_of
from cavesim.gpu.render.wall_renderer import WallRenderer
from cavesim.gpu.window import Region, WallWindow
from nodes.wall.preview_controls import help_line
from nodes.wall.title import FrameRate

HELP_AT = (4, 4)  # pixels from the preview window's lower left corner


class WallScreen:
    """A node's walls, live, side by side in one window (one wall: the whole window): every
    frame drawn for its eyes and presented, PNGs of what the window shows of each wall every
    `render_every` frames when `images` is given."""

    def __init__(self, window: WallWindow, system: ParticleSystem, walls: tuple[Wall, ...],
                 eye_separation: float, images: Path | None = None,
                 render_every: int = 0) -> None:
        self.window = window
        self.renderers = {w.name: WallRenderer(window.ctx, system, w) for w in walls}
        self.regions = dict(zip(self.renderers, side_by_side(walls), strict=True))
        self.eye_separation = eye_separation
        self.swap_locked = any(w.display.swap_lock for w in walls)
        self.images = None if images is None else Path(images)
        for wall in self.renderers if self.images is not None else ():
            (self.images / wall).mkdir(parents=True, exist_ok=True)
        self.render_every = render_every

    def draw(self, k: int, message: FrameMessage, scene: SceneFrame) -> None:
        stereo = self.window.stereo is not StereoMode.MONO
        eyes = eye_positions(message.head.position, message.head.orientation,
                             self.eye_separation, stereo)
        for wall, renderer in self.renderers.items():
            for eye, position in eyes.items():
                renderer.draw(position, scene.helicopter)
                self.window.present(renderer.picture, eye, self.regions[wall])
        if self.images is not None and self.render_every and k % self.render_every == 0:
            for wall, region in self.regions.items():
                path = self.images / wall / f"frame_{k:06d}.png"
                with writing(path):
                    Image.fromarray(self.window.read(region)).save(path, compress_level=1)


def side_by_side(walls: tuple[Wall, ...]) -> tuple[Region, ...]:
    """Each wall's region of a window that shows them left to right at their resolutions,
    on its bottom edge."""
    width, height = window_size(walls)
    regions, x = [], 0
    for w in walls:
        regions.append((x / width, 0.0, w.resolution[0] / width, w.resolution[1] / height))
        x += w.resolution[0]
    return tuple(regions)


def window_size(walls: tuple[Wall, ...]) -> tuple[int, int]:
    """The pixels of a window with `walls` side by side."""
    return sum(w.resolution[0] for w in walls), max(w.resolution[1] for w in walls)


class PreviewScreen:
    """Every wall of the CAVE at `scale` of its resolution, unfolded as the composites are,
    from the tracked (or scripted) head, in one window, with a line of help over it and the
    frame and frame rate in its title."""

    swap_locked = False  # a desktop preview follows the cluster, it does not hold it

    def __init__(self, window: WallWindow, system: ParticleSystem, cave: Cave,
                 scale: float, title: str) -> None:
        self.window = window
        self.cave = cave.scaled(scale)
        self.renderers = {w.name: WallRenderer(window.ctx, system, w) for w in self.cave.walls}
        self.picture = window.ctx.texture(slots_of(self.cave)[1], 3)
        self.help = TextLine(window.ctx, help_line())
        self.rate = FrameRate(title)

    @property
    def size(self) -> tuple[int, int]:
        return self.picture.size

    def draw(self, k: int, message: FrameMessage, scene: SceneFrame) -> None:
        (eye,) = eye_positions(message.head.position, message.head.orientation).values()
        pictures = {name: r.render(eye, scene.helicopter) for name, r in self.renderers.items()}
        unfolded = np.asarray(compose(self.cave, pictures))
        self.picture.write(np.ascontiguousarray(unfolded[::-1]).tobytes())  # GL: bottom row first
        self.window.present(self.picture, "center")
        self.window.overlay(self.help, HELP_AT)
        if (title := self.rate.title(k, time.monotonic(), message.inputs.dt == 0)) is not None:
            self.window.set_title(title)


class LiveDisplay:
    """A node's part of the swap barrier: it draws frame k into the back buffer after its
    report, finishes the GPU's work, says DRAWN k, and swaps on the master's SWAP k (a wall
    with `swap_lock = false`, or the preview, swaps at once); after each swap it says
    SWAPPED k with its clock. Frame k + 1 also releases k: the master sends it only after
    SWAP k (and every wall's SWAPPED k, or its timeout), and Zenoh keeps no order between
    the two keys."""

    def __init__(self, screen: WallScreen | PreviewScreen,
                 publish: Callable[[int, Phase, int], None]) -> None:
        self.screen = screen
        self.window = screen.window
        self.publish = publish
        self.pending: int | None = None  # a frame drawn, waiting for its SWAP

    def show(self, k: int, message: FrameMessage, scene: SceneFrame) -> None:
        if self.pending is not None:  # frame k came before SWAP k - 1: it was released
            self.swap(self.pending)
        self.screen.draw(k, message, scene)
        self.window.ctx.finish()  # the swap itself must be quick: the walls swap together
        self.pending = k
        if self.screen.swap_locked:
            self.publish(k, Phase.DRAWN, time.monotonic_ns())
        else:
            self.swap(k)

    def swap(self, k: int) -> None:
        """Swap frame k if it is the one drawn and waiting (a repeated SWAP does nothing)."""
        if self.pending != k:
            return
        self.pending = None
        self.publish(k, Phase.SWAPPED, self.window.swap())

    def closed(self) -> bool:
        """Whether the window was asked to close (the node then leaves)."""
        return self.window.should_close()

    def close(self) -> None:
        self.window.close()
