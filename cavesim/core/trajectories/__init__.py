"""Particle trajectories: a stable identity (the birth index) across the engine's
compaction, the tracked particles' rows, and trajectories.parquet (docs/trajectories.md).

Three modules, in the order of the data's flow: `identity` (which particles a run follows,
and each live particle's birth index across compaction), `recording` (after each step of the
GL engine or the float64 twin, the tracked particles' rows) and `parquet_file` (the file: its
columns and metadata, its writing, and its loading for pandas and xarray). Pure numpy and
pyarrow. Names are imported on first use, so a command that only parses its flags does not
load pyarrow.
"""

from importlib import import_module

FILE_NAME = "trajectories.parquet"  # in a run's or a replay's folder; here: the CLI reads it

_WHERE = {
    "COLUMNS": "parquet_file", "arrow_schema": "parquet_file",
    "file_metadata": "parquet_file", "read_table": "parquet_file", "to_dataset": "parquet_file",
    "HOST_BYTES_PER_PARTICLE": "identity", "BirthIndex": "identity", "Selection": "identity",
    "SteppedSystem": "recording", "TrajectoryRecorder": "recording",
    "TrajectoryRecording": "recording", "TrajectoryRequest": "recording",
}
__all__ = sorted([*_WHERE, "FILE_NAME"])


def __getattr__(name: str):
    if name not in _WHERE:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(import_module(f"{__name__}.{_WHERE[name]}"), name)
