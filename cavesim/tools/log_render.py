"""Drawing a run again from its frame log: the logged frames re-run on one engine, each
checked against the checksum the cluster agreed on, and the walls drawn at the frames
asked for from the logged head pose, as the wall nodes drew them.

Every frame depends on the ones before, so the replay starts at frame 1 whatever the
first frame drawn. It stops at the first frame whose checksum differs: from there on the
state is no longer the run's, and neither would its pictures be.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from cavesim.core.cave.geometry import Cave
from cavesim.gpu.render.painter import WallPainter
from cavesim.tools.log_replay import LogReplay, ReplayResult


@dataclass(frozen=True)
class RenderPlan:
    cave: Cave
    images: Path  # <wall>/frame_<k>.png go here
    first: int = 1  # the frames drawn: first..last, those a multiple of `every`
    last: int | None = None  # None: the log's last whole frame
    every: int = 10
    stereo: bool = False

    def draws(self, k: int) -> bool:
        return self.first <= k and k % self.every == 0


@dataclass
class Rendered:
    replay: ReplayResult
    pictures: int = 0  # wall pictures written
    dt: float = 0.0  # s: the logged frames' step


def render_log(replay: LogReplay, plan: RenderPlan,
               progress: Callable[[int], None] = lambda k: None) -> Rendered:
    """Re-run `replay`'s frames up to the plan's last, drawing the plan's frames; stop
    after the first frame whose checksum differs from the log's."""
    painter = WallPainter(replay.system.ctx, replay.system, plan.cave, plan.cave.names,
                          plan.images, plan.stereo)
    rendered = Rendered(replay.result)
    for logged in replay.frames:
        k = logged.message.frame
        if plan.last is not None and k > plan.last:
            break
        scene = replay.step(logged)
        rendered.dt = float(logged.message.inputs.dt)
        if replay.result.mismatches:
            break
        if plan.draws(k):
            rendered.pictures += len(painter.paint(k, logged.message, scene))
        progress(k)
    return rendered
