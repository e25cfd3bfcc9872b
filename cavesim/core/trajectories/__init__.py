"""Particle trajectories: a stable identity (the birth index) across the engine's
compaction, the tracked particles' rows, and trajectories.parquet (docs/trajectories.md).

Pure numpy and pyarrow; the GL engine's readback is `cavesim.gpu.engine.trajectory_stream`.
"""

from cavesim.core.trajectories.identity import HOST_BYTES_PER_PARTICLE, BirthIndex
from cavesim.core.trajectories.recorder import TrajectoryRecorder
from cavesim.core.trajectories.recording import TrajectoryRecording, TrajectoryRequest
from cavesim.core.trajectories.schema import COLUMNS, FILE_NAME, arrow_schema
from cavesim.core.trajectories.selection import MAX_TRAJECTORIES, Selection
from cavesim.core.trajectories.stream import ParticleStream, TwinStream

__all__ = ["COLUMNS", "FILE_NAME", "HOST_BYTES_PER_PARTICLE", "MAX_TRAJECTORIES",
           "BirthIndex", "ParticleStream", "Selection", "TrajectoryRecorder",
           "TrajectoryRecording", "TrajectoryRequest", "TwinStream", "arrow_schema"]
