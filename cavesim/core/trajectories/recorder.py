"""Per frame, the tracked particles' rows: the birth index follows the step
(`identity.BirthIndex`), and every K frames the tracked ones are read and made a table.

Sits after a frame's step (a wall node's, a replay's, a test's twin) and before the file
(`parquet_file.TrajectoryFile`)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pyarrow as pa

from cavesim.core.position import low_part
from cavesim.core.scene.model import Scene
from cavesim.core.trajectories.identity import BirthIndex, Selection
from cavesim.core.trajectories.parquet_file import arrow_schema
from cavesim.core.trajectories.stream import ParticleStream


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

    def after_step(self, frame: int, dt: float, stream: ParticleStream) -> None:
        """Follow frame `frame`'s step of `dt` (just taken by `stream`)."""
        survivors = stream.survivors()
        newborns = stream.records(survivors, stream.live_count - survivors)
        self.index.advance(dt, survivors, newborns, lambda: stream.records(0, survivors))
        self.time += float(np.float32(dt))
        self.frame = frame
        if frame % self.every == 0:
            picks = np.flatnonzero(self.selection.tracked(self.index.ids))
            table = self.table(frame, self.index.ids[picks], stream.picked(picks))
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
