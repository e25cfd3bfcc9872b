"""Replaying a frame log on one engine: every recorded checksum must come back bit for bit.

The replay takes the log's whole records and stops where it is torn or corrupt (every
frame depends on the ones before); `damage` says where.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from cavesim.core.drivers import driver_for
from cavesim.core.framelog import Damage, read_frame_log
from cavesim.core.scene import load_scene
from cavesim.gpu.engine import ParticleSystem
from cavesim.gpu.gl.context import create_context


@dataclass
class ReplayResult:
    log: str
    scene: str
    frames: int = 0
    mismatches: list[dict] = field(default_factory=list)
    damage: Damage | None = None  # where the log stops being readable

    @property
    def equal(self) -> bool:
        return self.frames > 0 and not self.mismatches

    def summary(self) -> dict:
        return {"log": self.log, "scene": self.scene, "frames": self.frames,
                "equal": self.equal, "mismatches": self.mismatches[:100],
                "mismatch_count": len(self.mismatches),
                "damage": self.damage.to_json() if self.damage else None}


def replay(log_path: Path, scene_path: Path | None = None, ctx=None,
           progress: Callable[[int], None] = lambda k: None) -> ReplayResult:
    """Step the logged inputs on one context and compare each frame's checksum."""
    header, frames = read_frame_log(log_path)
    scene_path = Path(scene_path or header["scene"])
    scene = load_scene(scene_path)
    system, driver = ParticleSystem(ctx or create_context(), scene), driver_for(scene)
    result = ReplayResult(str(log_path), str(scene_path), damage=frames.damage)
    for logged in frames:
        system.step(logged.message.inputs, driver.decode(logged.message.params))
        state = system.checksum()
        result.frames += 1
        if state.digest != logged.digest or state.particles != logged.particles:
            result.mismatches.append({"frame": logged.message.frame, "logged": logged.digest,
                                      "replayed": state.digest, "logged_particles":
                                      logged.particles, "replayed_particles": state.particles})
        progress(logged.message.frame)
    system.release()
    return result
