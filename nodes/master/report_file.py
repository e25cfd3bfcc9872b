"""report.json kept current while the master runs, so that a crash or SIGKILL of the master
leaves it behind whole.

The master hands its `RunRecord` to `ReportFile.checkpoint` after every frame; the file is
replaced atomically (`cavesim.core.output.write_atomically`) after the first frame, then at
most once every CHECKPOINT_SECONDS, and never more often than keeps its writing under
1/BUDGET_RATIO of the run (the summary grows with the run). Its `ended` field tells a
reader what the file is: RUNNING in a checkpoint (the master may be gone since), then
FINISHED, INTERRUPTED or FAILED (with the `error` line) once the run is over.
"""

from __future__ import annotations

import json
import time
from contextlib import suppress
from pathlib import Path

from cavesim.core.errors import OutputError
from cavesim.core.output import write_atomically
from nodes.master.run_record import RunRecord

RUNNING, FINISHED, INTERRUPTED, FAILED = "running", "finished", "interrupted", "failed"
CHECKPOINT_SECONDS = 1.0
BUDGET_RATIO = 20  # a checkpoint that took t seconds waits at least BUDGET_RATIO * t


class ReportFile:
    """report.json of one run: checkpoints while it runs, the final report at the end; as a
    context manager, an error that ends the run is written as FAILED before it goes on."""

    def __init__(self, path: Path, every_seconds: float = CHECKPOINT_SECONDS) -> None:
        self.path = Path(path)
        self.every_seconds = every_seconds
        self._record: RunRecord | None = None  # the master's, as of the last checkpoint
        self._due = 0.0  # monotonic time of the next checkpoint

    def checkpoint(self, record: RunRecord) -> None:
        """The master's call after each frame: write the record if a checkpoint is due."""
        self._record = record
        started = time.monotonic()
        if started < self._due:
            return
        self._write(record.summary(), RUNNING)
        took = time.monotonic() - started
        self._due = started + max(self.every_seconds, BUDGET_RATIO * took)

    def finish(self, report: dict, interrupted: bool) -> Path:
        """Write the run's final report (OutputError if it cannot be)."""
        return self._write(report, INTERRUPTED if interrupted else FINISHED)

    def _write(self, report: dict, ended: str) -> Path:
        write_atomically(self.path, json.dumps({"ended": ended, **report}, indent=2) + "\n")
        return self.path

    def __enter__(self) -> ReportFile:
        return self

    def __exit__(self, kind, error, trace) -> None:
        if error is None or self._record is None:
            return
        ended = INTERRUPTED if isinstance(error, KeyboardInterrupt) else FAILED
        with suppress(OutputError):  # the run's own error is the one to tell
            self._write({**self._record.summary(), "error": str(error)}, ended)
