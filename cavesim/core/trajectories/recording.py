"""One run's trajectories: the recorder feeding the file, opened with the run's metadata.

Both `cavesim run` (on one wall node) and `cavesim replay` open one with the same
arguments, so the two files hold the same table."""

from __future__ import annotations

from dataclasses import dataclass
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

import numpy as np

from cavesim.core.scene.digest import scene_digest
from cavesim.core.scene.model import Scene
from cavesim.core.trajectories import FILE_NAME
from cavesim.core.trajectories.identity import Selection
from cavesim.core.trajectories.parquet_file import TrajectoryFile
from cavesim.core.trajectories.recorder import TrajectoryRecorder
from cavesim.core.trajectories.stream import ParticleStream


@dataclass(frozen=True)
class TrajectoryRequest:
    count: int  # N: particles to track (at most)
    every: int  # K: a row every K frames (frame % K == 0)
    frames: int  # the run's planned frames ...
    dt: float  # ... and its nominal dt, s: they fix the stride (`selection.expected_births`)


class TrajectoryRecording:
    """trajectories.parquet in `folder`, filled frame by frame; `finish` or `abort` it."""

    def __init__(self, folder: Path, scene: Scene, request: TrajectoryRequest,
                 digest: str | None = None) -> None:
        """`digest`: the scene file's (a node's scene may differ in its engine path only)."""
        self.selection = Selection.for_run(scene, request.count, request.frames,
                                            request.dt)
        origin = scene.origin or (0.0, 0.0, 0.0)
        self.file = TrajectoryFile(Path(folder) / FILE_NAME, {
            "cavesim_version": cavesim_version(), "scene": scene.name,
            "scene_digest": digest or scene_digest(scene),
            "scene_origin": ",".join(repr(float(c)) for c in origin),
            "trajectories": str(request.count), "every": str(request.every),
            "stride": str(self.selection.stride)})
        self.recorder = TrajectoryRecorder(scene, self.selection, request.every,
                                           self.file.write)

    def restart(self) -> None:
        self.recorder.restart()

    def after_step(self, frame: int, dt: float, stream: ParticleStream) -> None:
        try:
            self.recorder.after_step(frame, dt, stream)
        except BaseException:
            self.file.abort()
            raise

    def holds(self, records: np.ndarray) -> bool:
        """Whether a stream loaded from elsewhere (a resync) is the one being followed."""
        return self.recorder.index.holds(records)

    def finish(self) -> Path:
        """The complete file, named; its footer says the last frame followed."""
        frame = self.recorder.frame
        return self.file.finish({"frames": str(0 if frame is None else frame),
                                 "ambiguous_drops": str(self.recorder.index.ambiguous_drops)})

    def abort(self) -> None:
        self.file.abort()


def cavesim_version() -> str:
    try:
        return version("cavesim")
    except PackageNotFoundError:
        return "unknown"
