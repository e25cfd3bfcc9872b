"""One run's trajectories, frame by frame: after each step the birth index follows the stream
(`identity.BirthIndex`), and every K frames the tracked particles' rows go to the file
(`parquet_file.TrajectoryFile`).

Sits after a frame's step: a wall node's, a replay's or a test's. The recorder reads the
system that stepped, the GL engine or the float64 twin, through the reads both offer
(`SteppedSystem`). Per frame: the emitter stream's counts (16 bytes an emitter) and the
newborns' records (40 bytes each); every K frames the tracked particles' records (40 bytes
each, one read per run of consecutive ones); the survivors' records only after a runaway
drop. Both `cavesim run` (on one wall node) and `cavesim replay` open a
`TrajectoryRecording` with the same arguments, so the two files hold the same table.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path
from typing import Protocol

import numpy as np
import pyarrow as pa

from cavesim.core.digest.shape import PARTICLES
from cavesim.core.position import low_part
from cavesim.core.records import PARTICLE_DTYPE
from cavesim.core.scene.digest import scene_digest
from cavesim.core.scene.model import Scene
from cavesim.core.trajectories import FILE_NAME
from cavesim.core.trajectories.identity import BirthIndex, Selection
from cavesim.core.trajectories.parquet_file import TrajectoryFile, arrow_schema


class SteppedSystem(Protocol):
    """What the recorder reads of a system after its step: the reads of the GL engine
    (`cavesim.gpu.engine.ParticleSystem`), which the twin (`TwinSystem`) offers too. On the
    engine each waits for the step."""

    @property
    def live_count(self) -> int: ...

    def dropped(self) -> int:
        """New particles the last step dropped because the capacity was full."""

    def read_emitters(self) -> np.ndarray:
        """The emitter stream (EMITTER_DTYPE): `count`, what each emitted in the last step."""

    def read_particle_chunk(self, first: int, count: int) -> bytes:
        """Records [first, first + count) of the live particle stream."""

    def read_records(self, stream: int, indices: np.ndarray) -> bytes:
        """Records at the ascending `indices` of `stream` (PARTICLES)."""


def survivors(system: SteppedSystem) -> int:
    """Particles of the stream before the last step that are still in it: live = survivors +
    emitted - dropped (cavesim/gpu/engine/drops.py)."""
    return system.live_count + system.dropped() - int(system.read_emitters()["count"].sum())


def read_span(system: SteppedSystem, first: int, count: int) -> np.ndarray:
    """Records [first, first + count) of the live stream (PARTICLE_DTYPE)."""
    return np.frombuffer(system.read_particle_chunk(first, count), PARTICLE_DTYPE)


@dataclass(frozen=True)
class TrajectoryRequest:
    count: int  # N: particles to track (at most)
    every: int  # K: a row every K frames (frame % K == 0)
    frames: int  # the run's planned frames ...
    dt: float  # ... and its nominal dt, s: they fix the stride (`identity.expected_births`)


class TrajectoryRecorder:
    """Follows every step of one run and hands each K-th frame's rows to `sink`."""

    def __init__(self, scene: Scene, selection: Selection, every: int,
                 sink: Callable[[pa.Table], None]) -> None:
        if every < 1:
            raise ValueError(f"every must be >= 1 frame, got {every!r}")
        self.selection, self.every, self.sink = selection, every, sink
        self.class_names = np.array([c.name for c in scene.particle_classes], dtype=object)
        self.origin = np.array(scene.origin or (0.0, 0.0, 0.0), dtype=np.float64)
        self.index = BirthIndex()
        self.time = 0.0  # s since the run's start or its last reset
        self.frame: int | None = None  # the last frame followed
        self.rows = 0

    def restart(self) -> None:
        """The run went back to the scene's start state (the master's reset)."""
        self.index.restart()
        self.time = 0.0

    def after_step(self, frame: int, dt: float, system: SteppedSystem) -> None:
        """Follow frame `frame`'s step of `dt`, just taken by `system`."""
        kept = survivors(system)
        newborns = read_span(system, kept, system.live_count - kept)
        self.index.advance(dt, kept, newborns, lambda: read_span(system, 0, kept))
        self.time += float(np.float32(dt))
        self.frame = frame
        if frame % self.every == 0:
            picks = np.flatnonzero(self.selection.tracked(self.index.ids))
            records = np.frombuffer(system.read_records(PARTICLES, picks), PARTICLE_DTYPE)
            table = self.table(frame, self.index.ids[picks], records)
            self.rows += table.num_rows
            self.sink(table)

    def table(self, frame: int, ids: np.ndarray, records: np.ndarray) -> pa.Table:
        """One frame's rows, in id order (the stream's)."""
        position = records["pos"].astype(np.float64) \
            + low_part(records["pos"], records["pos_low"]).astype(np.float64) + self.origin
        n = len(ids)
        columns = {
            "frame": np.full(n, frame, np.int64), "time": np.full(n, self.time, np.float64),
            "id": ids, "class": self.class_names[records["class_id"]].tolist(),
            "x": position[:, 0], "y": position[:, 1], "z": position[:, 2],
            "u": records["vel"][:, 0], "v": records["vel"][:, 1], "w": records["vel"][:, 2],
        }
        schema = arrow_schema()
        return pa.table([pa.array(columns[f.name], f.type) for f in schema], schema=schema)


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

    def after_step(self, frame: int, dt: float, system: SteppedSystem) -> None:
        try:
            self.recorder.after_step(frame, dt, system)
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
