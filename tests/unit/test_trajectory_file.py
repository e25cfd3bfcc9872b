"""trajectories.parquet never claims to be complete when it is not: rows go to a partial
name, only `finish` gives the file its name; an abort or a full disk leaves nothing."""

import errno

import numpy as np
import pyarrow.parquet as pq
import pytest
from fountain import DT, fountain, steps

from cavesim.core.errors import OutputError
from cavesim.core.trajectories import Selection, TrajectoryRecorder, file_metadata
from cavesim.core.trajectories.parquet_file import (
    METADATA_AT_CLOSE,
    METADATA_AT_OPEN,
    TrajectoryFile,
)
from cavesim.core.trajectories.recording import TrajectoryRecording, TrajectoryRequest
from cavesim.core.twin.system import TwinSystem


def recorded(tmp_path, frames=30):
    scene = fountain()
    twin = TwinSystem(scene)
    recording = TrajectoryRecording(tmp_path, scene, TrajectoryRequest(10, 3, frames, DT))
    for k in steps(twin, frames):
        recording.after_step(k, DT, twin)
    return recording


def test_the_file_is_named_only_when_finished(tmp_path):
    recording = recorded(tmp_path)
    assert not (tmp_path / "trajectories.parquet").exists()
    assert (tmp_path / ".trajectories.parquet.partial").exists()
    path = recording.finish()
    assert path == tmp_path / "trajectories.parquet" and not recording.file.partial.exists()
    assert set(file_metadata(path)) == {*METADATA_AT_OPEN, *METADATA_AT_CLOSE}
    assert pq.read_table(path).num_rows == recording.recorder.rows > 0


def test_an_aborted_file_leaves_nothing(tmp_path):
    recorded(tmp_path).abort()
    assert list(tmp_path.iterdir()) == []


def test_a_full_disk_is_one_error_naming_the_file_and_leaves_nothing(tmp_path, monkeypatch):
    recording = recorded(tmp_path)

    def full(*args, **kwargs):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(recording.file._writer, "write_table", full)
    with pytest.raises(OutputError, match=r"cannot write .*\.trajectories\.parquet\.partial"):
        recording.finish()
    assert list(tmp_path.iterdir()) == []


def test_an_unwritable_folder_is_one_error(tmp_path):
    with pytest.raises(OutputError, match="cannot write"):
        TrajectoryFile(tmp_path / "gone" / "trajectories.parquet", {})


def test_the_recorder_refuses_every_zero():
    with pytest.raises(ValueError, match=r"every must be >= 1 frame, got 0"):
        TrajectoryRecorder(fountain(), Selection(1, 1), 0, print)


def test_row_groups_hold_the_rows_in_frame_and_id_order(tmp_path):
    path = recorded(tmp_path, frames=60).finish()
    frame = pq.read_table(path).to_pandas()
    order = np.lexsort((frame["id"].to_numpy(), frame["frame"].to_numpy()))
    assert (order == np.arange(len(frame))).all()
