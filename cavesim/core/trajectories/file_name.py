"""The trajectories file's name in a run's or a replay's folder (no pyarrow: the CLI reads it)."""

FILE_NAME = "trajectories.parquet"
