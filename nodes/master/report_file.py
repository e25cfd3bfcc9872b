"""report.json kept current while the master runs, so that a crash or SIGKILL of the master
leaves it behind whole.

The master hands its `RunRecord` to `ReportFile.checkpoint` when the run starts and after
every frame; the file is replaced atomically (`cavesim.core.output.write_atomically`) at
the start and the first frame, then at most once every CHECKPOINT_SECONDS, and never more
often than keeps its writing under 1/BUDGET_RATIO of the run (the summary grows with the
run). Its `ended` field tells a reader what the file is: RUNNING in a checkpoint (the
master may be gone since), then FINISHED, STOPPED, INTERRUPTED (with the `signal`) or FAILED
(with the `error` line) once the run is over, and `ended_during` when: START_UP (before its
first frame: the processes starting, the walls joining) or RUN. The file says it even when
the run ends before its record exists (an interruption or an error while it starts): then
with START_UP's few fields.

A full disk must not leave a checkpoint saying RUNNING behind: an atomic replacement needs
room for a whole new file, while the frame log's small appends still fit in its last
block. So each checkpoint keeps twice its size (and a margin) in reserve, in a hidden file
beside the report; when the last report cannot be written, the reserve is given up for it.
"""

from __future__ import annotations

import json
import os
import time
from contextlib import suppress
from pathlib import Path

from cavesim.core.errors import OutputError
from cavesim.core.output import write_atomically, writing
from cavesim.tools.signals import held, signal_of
from nodes.master.run_record import RunRecord

RUNNING, FINISHED, INTERRUPTED, FAILED = "running", "finished", "interrupted", "failed"
STOPPED = "stopped"  # at the user's request (Esc in the preview window)
START_UP, RUN = "start-up", "run"  # ended_during: before the first frame, or after
CHECKPOINT_SECONDS = 1.0
BUDGET_RATIO = 20  # a checkpoint that took t seconds waits at least BUDGET_RATIO * t
RESERVE_MARGIN = 16 * 1024  # bytes held beyond twice the last checkpoint: the final fields


class Reserve:
    """Disk space held in a file, to be given up when the report cannot be written."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.size = 0  # bytes held

    def keep(self, size: int) -> None:
        """Hold at least `size` bytes (OutputError when the disk has no room left)."""
        if size <= self.size:
            return
        with writing(self.path), open(self.path, "ab") as file:
            file.write(bytes(size - self.size))
            file.flush()
            os.fsync(file.fileno())
        self.size = size

    def release(self) -> bool:
        """Give the space back; whether any was held."""
        held = self.path.exists()
        self.path.unlink(missing_ok=True)
        self.size = 0
        return held


class ReportFile:
    """report.json of one run: checkpoints while it runs, the final report at the end; as a
    context manager, an error that ends the run is written as FAILED before it goes on."""

    def __init__(self, path: Path, every_seconds: float = CHECKPOINT_SECONDS) -> None:
        self.path = Path(path)
        self.every_seconds = every_seconds
        self._record: RunRecord | None = None  # the master's, as of the last checkpoint
        self._due = 0.0  # monotonic time of the next checkpoint
        self._reserve = Reserve(self.path.with_name(f".{self.path.name}.reserve"))

    def checkpoint(self, record: RunRecord) -> None:
        """The master's call when the run starts and after each frame: write the record if
        a checkpoint is due."""
        self._record = record
        started = time.monotonic()
        if started < self._due:
            return
        size = self._write(record.summary(), RUNNING)
        self._reserve.keep(2 * size + RESERVE_MARGIN)
        if record.frames:  # the start's checkpoint does not put off the first frame's
            took = time.monotonic() - started
            self._due = started + max(self.every_seconds, BUDGET_RATIO * took)

    def finish(self, report: dict, interrupted: bool, stopped: bool = False) -> Path:
        """Write the run's final report (OutputError if it cannot be); `stopped`: the user
        ended it."""
        self._write(report, INTERRUPTED if interrupted else STOPPED if stopped else FINISHED)
        self._reserve.release()
        return self.path

    def _write(self, report: dict, ended: str) -> int:
        """Replace the file; its size in bytes. On a full disk the reserve makes room."""
        during = {} if ended == RUNNING else {
            "ended_during": RUN if report.get("frames") else START_UP}
        text = json.dumps({"ended": ended, **during, **report}, indent=2) + "\n"
        try:
            write_atomically(self.path, text)
        except OutputError:
            if not self._reserve.release():
                raise
            write_atomically(self.path, text)
        return len(text.encode())

    def __enter__(self) -> ReportFile:
        return self

    def __exit__(self, kind, error, trace) -> None:
        with held():  # a second signal does not cut the last report off
            if error is not None:
                report = self._record.summary() if self._record is not None else {"frames": 0}
                if isinstance(error, KeyboardInterrupt):
                    ended, why = INTERRUPTED, {"interrupted": True, "signal": signal_of(error)}
                else:
                    ended, why = FAILED, {"error": str(error)}
                with suppress(OutputError):  # the run's own error is the one to tell
                    self._write({**report, **why}, ended)
            self._reserve.release()
