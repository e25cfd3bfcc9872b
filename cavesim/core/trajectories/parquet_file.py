"""trajectories.parquet, written so that a killed run or a full disk never leaves a file
that claims to be complete.

Rows go to `.trajectories.parquet.partial` beside the final name, in row groups of
ROW_GROUP_ROWS rows (the writer holds at most one group in memory); `finish` writes the
footer with the closing metadata and renames the file to its name. A run that is killed
or fails leaves no trajectories.parquet (`abort` removes the partial file; a SIGKILL may
leave the partial one, which has no footer and no reader opens)."""

from __future__ import annotations

import os
from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq

from cavesim.core.output import writing
from cavesim.core.trajectories.columns import arrow_schema

ROW_GROUP_ROWS = 65_536


class TrajectoryFile:
    """An open trajectories file: `write` tables of its schema, then `finish` or `abort`."""

    def __init__(self, path: Path, metadata: dict[str, str]) -> None:
        self.path = Path(path)
        self.partial = self.path.with_name(f".{self.path.name}.partial")
        self.schema = arrow_schema(metadata)
        self._pending: list[pa.Table] = []
        self._pending_rows = 0
        self._named = False
        with writing(self.partial):
            self._writer = pq.ParquetWriter(self.partial, self.schema, compression="zstd")

    def write(self, table: pa.Table) -> None:
        self._pending.append(table)
        self._pending_rows += table.num_rows
        if self._pending_rows >= ROW_GROUP_ROWS:
            self._flush()

    def _flush(self) -> None:
        if not self._pending:
            return
        table = pa.concat_tables(self._pending).replace_schema_metadata(self.schema.metadata)
        self._pending, self._pending_rows = [], 0
        with writing(self.partial):
            self._writer.write_table(table, row_group_size=ROW_GROUP_ROWS)

    def finish(self, metadata: dict[str, str]) -> Path:
        """Write the last rows and the footer (with `metadata` added) and give the file its
        name."""
        try:
            self._flush()
            self._writer.add_key_value_metadata(metadata)
            with writing(self.partial):
                self._writer.close()
                os.replace(self.partial, self.path)
            self._named = True
        except BaseException:
            self.abort()
            raise
        return self.path

    def abort(self) -> None:
        """Drop the file, unless `finish` named it: nothing is left under either name."""
        if self._named:
            return
        try:
            self._writer.close()
        except (OSError, pa.ArrowException):  # the file is removed whatever its state
            pass
        self.partial.unlink(missing_ok=True)
