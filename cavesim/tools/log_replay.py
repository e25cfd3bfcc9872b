"""Replaying a frame log on one engine: every recorded checksum must come back bit for bit.

The replay takes the log's whole records and stops where it is torn or corrupt (every
frame depends on the ones before); `damage` says where. A log of any version the frame log
reads (4, or 3 from before the log had a record layout of its own) replays the same way.
The scene must be the run's: its digest (`cavesim.core.scene.digest`) must be the one the
log's header names. A scene given by hand overrides that check, with a warning; a log
written before headers named the digest is replayed with a warning that nothing could be
checked.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from cavesim.core.drivers import driver_for
from cavesim.core.framelog import Damage, LoggedFrame, LoggedFrames, read_frame_log
from cavesim.core.scene import load_scene
from cavesim.core.scene.digest import scene_digest
from cavesim.core.scene_frame import SceneFrame
from cavesim.core.trajectories import TrajectoryRecording, TrajectoryRequest
from cavesim.gpu.engine import ParticleSystem
from cavesim.gpu.gl.context import create_context


@dataclass
class ReplayResult:
    log: str
    scene: str
    frames: int = 0
    mismatches: list[dict] = field(default_factory=list)
    damage: Damage | None = None  # where the log stops being readable
    warnings: list[str] = field(default_factory=list)  # about the scene it was given
    trajectories: str | None = None  # the trajectories file written, if asked

    @property
    def equal(self) -> bool:
        return self.frames > 0 and not self.mismatches

    def summary(self) -> dict:
        return {"log": self.log, "scene": self.scene, "frames": self.frames,
                "equal": self.equal, "mismatches": self.mismatches[:100],
                "mismatch_count": len(self.mismatches),
                "damage": self.damage.to_json() if self.damage else None,
                "warnings": self.warnings, "trajectories": self.trajectories}


class LogReplay:
    """A frame log opened on one engine, stepped a logged frame at a time; `result` keeps
    what came back (ValueError when the log's own scene file no longer holds the run's
    scene)."""

    def __init__(self, log_path: Path, scene_path: Path | None = None, ctx=None,
                 trajectories: TrajectoryRecording | None = None) -> None:
        self.header, self.frames = read_frame_log(log_path)
        given = scene_path is not None
        scene_path = Path(scene_path) if given else logged_scene(self.header, log_path)
        scene = load_scene(scene_path)
        warnings = scene_warnings(self.header.get("scene_digest"), scene_digest(scene),
                                  scene_path, given)
        self.system, self.driver = ParticleSystem(ctx or create_context(), scene), \
            driver_for(scene)
        self.result = ReplayResult(str(log_path), str(scene_path), damage=self.frames.damage,
                                   warnings=warnings)
        self.scene = scene
        self.trajectories: TrajectoryRecording | None = None

    def step(self, logged: LoggedFrame) -> SceneFrame:
        """Step one logged frame and compare its checksum (a mismatch joins `result`);
        the frame's decoded scene parameters."""
        scene = self.driver.decode(logged.message.params)
        if logged.message.reset:  # the run went back to the scene's start before this step
            self.system.restart(self.system.scene.seed)
            if self.trajectories is not None:
                self.trajectories.restart()
        self.system.step(logged.message.inputs, scene)
        if self.trajectories is not None:
            self.trajectories.after_step(logged.message.frame, logged.message.inputs.dt,
                                         self.system)
        state = self.system.checksum()
        self.result.frames += 1
        if state.digest != logged.digest or state.particles != logged.particles:
            self.result.mismatches.append({
                "frame": logged.message.frame, "logged": logged.digest,
                "replayed": state.digest, "logged_particles": logged.particles,
                "replayed_particles": state.particles})
        return scene

    def record_trajectories(self, folder: Path, count: int, every: int) -> None:
        """Write trajectories.parquet into `folder` as the run did (`cavesim run
        --trajectories`): its selection comes from the log header's planned frames and dt
        (ValueError if the header's are no such)."""
        try:
            planned = planned_run(self.header, self.frames)
        except ValueError as e:
            raise ValueError(f"{self.result.log}: {e}") from e
        self.trajectories = TrajectoryRecording(folder, self.scene, TrajectoryRequest(
            count, every, *planned))

    def release(self) -> None:
        if self.trajectories is not None:
            self.trajectories.abort()  # unless finished: then there is nothing to remove
        self.system.release()

    def __enter__(self) -> LogReplay:
        return self

    def __exit__(self, *exc) -> None:
        self.release()


def replay(log_path: Path, scene_path: Path | None = None, ctx=None,
           progress: Callable[[int], None] = lambda k: None,
           trajectories: tuple[Path, int, int] | None = None) -> ReplayResult:
    """Step the logged inputs on one context and compare each frame's checksum (ValueError
    when the log's own scene file no longer holds the run's scene); with `trajectories`
    (folder, N, K), write trajectories.parquet there."""
    with LogReplay(log_path, scene_path, ctx) as run:
        if trajectories is not None:
            run.record_trajectories(*trajectories)
        for logged in run.frames:
            run.step(logged)
            progress(logged.message.frame)
        if run.trajectories is not None:
            run.result.trajectories = str(run.trajectories.finish())
    return run.result


def logged_scene(header: dict, log_path: Path) -> Path:
    """The scene file the log's header names; ValueError if it names none."""
    scene = header.get("scene")
    if not isinstance(scene, str) or not scene:
        raise ValueError(f"{log_path}: its header names no scene file (scene = {scene!r}, "
                         f"expected a path): give the run's scene with --scene")
    return Path(scene)


def planned_run(header: dict, frames: LoggedFrames) -> tuple[int, float]:
    """The run's planned frames and nominal dt, as its header says (a log older than that:
    its whole records and the first one's dt); ValueError if the header's are no such."""
    if "frames" in header and "dt" in header:
        planned, dt = header["frames"], header["dt"]
        if type(planned) is not int or planned < 1 or type(dt) not in (int, float) \
                or not 0 < dt < math.inf:
            raise ValueError(f"its header plans frames = {planned!r} of dt = {dt!r}; expected "
                             f"an integer >= 1 and a number of seconds > 0")
        return planned, float(dt)
    first = next(iter(frames), None)
    return len(frames), float(first.message.inputs.dt) if first is not None else 1 / 60


def scene_warnings(logged: str | None, digest: str, scene_path: Path,
                   given: bool) -> list[str]:
    """What to say of replaying the scene at `scene_path` (digest `digest`) against the log's
    scene (`logged`; None in a log older than scene digests); ValueError when the log's own
    scene file holds another scene and no --scene overrides it."""
    if logged is None:
        return [f"the log names no scene digest (written before logs did): {scene_path} is "
                f"replayed unchecked"]
    if logged == digest:
        return []
    if not given:
        raise ValueError(f"the scene file {scene_path} the log names now holds scene {digest}, "
                         f"the run's was {logged}: give the run's scene with --scene")
    return [f"--scene {scene_path} is scene {digest}, the run's was {logged}: replayed as "
            f"asked (--scene overrides the check)"]
