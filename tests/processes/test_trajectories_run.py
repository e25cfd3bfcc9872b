"""`cavesim run --trajectories 50 --every 2` on the demo writes trajectories.parquet that
loads in pandas and in xarray with the documented columns; `cavesim replay` of the run's
frame log with the same flags writes an equal table; bad flags get one line each."""

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest
import xarray as xr

from cavesim.core.trajectories import COLUMNS, file_metadata, read_table, to_dataset

ROOT = Path(__file__).parents[2]
FRAMES, COUNT, EVERY = 24, 50, 2


def cavesim(*args: str, timeout: float = 300) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "cavesim", *args], capture_output=True,
                          text=True, timeout=timeout, cwd=ROOT)


@pytest.fixture(scope="module")
def run_folder(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("traj") / "run"
    result = cavesim("run", "--walls", "2", "--frames", str(FRAMES), "--render-every", "0",
                     "--out", str(out), "--session", f"traj{os.getpid()}",
                     "--trajectories", str(COUNT), "--every", str(EVERY))
    assert result.returncode == 0, result.stdout + result.stderr
    assert "trajectories.parquet" in result.stdout
    return out


def test_the_run_writes_the_documented_columns(run_folder):
    path = run_folder / "trajectories.parquet"
    assert json.loads((run_folder / "report.json").read_text())["trajectories"] == str(path)
    table = pq.read_table(path)
    assert [(f.name, f.type) for f in table.schema] == [(c.name, c.type) for c in COLUMNS]
    frame = read_table(path)
    assert list(frame.columns) == [c.name for c in COLUMNS]
    assert frame["frame"].dtype == np.int64 and frame["id"].dtype == np.uint64
    assert frame["x"].dtype == np.float64 and frame["u"].dtype == np.float32
    assert set(frame["frame"]) == set(range(EVERY, FRAMES + 1, EVERY))
    assert frame["id"].nunique() == COUNT  # the demo makes far more births than that
    # spread over the run: the stride counts the rotor's rate factors, not just the rates
    assert frame.groupby("id")["frame"].min().max() > FRAMES // 2
    assert frame.sort_values(["frame", "id"]).index.equals(frame.index)
    assert frame.attrs["frames"] == str(FRAMES) and frame.attrs["every"] == str(EVERY)
    assert int(frame.attrs["stride"]) > 1 and frame.attrs["scene"] == "brownout"
    assert not (run_folder / ".trajectories.parquet.partial").exists()


def test_the_file_loads_in_xarray_both_ways(run_folder):
    path = run_folder / "trajectories.parquet"
    frame = read_table(path)
    by_index = xr.Dataset.from_dataframe(frame.set_index(["id", "frame"]))
    assert by_index.sizes == {"id": COUNT, "frame": FRAMES // EVERY}
    tracks = to_dataset(path)
    assert tracks.sizes["trajectory"] == COUNT and tracks["x"].dims == ("trajectory", "obs")
    assert tracks["x"].attrs["units"] == "m" and tracks.attrs["trajectories"] == str(COUNT)
    first = frame[frame["id"] == frame["id"].iloc[0]]
    np.testing.assert_array_equal(tracks["x"].isel(trajectory=0)[:len(first)], first["x"])
    assert int(tracks["frame"].isel(trajectory=0, obs=0)) == first["frame"].iloc[0]


def test_the_replay_writes_the_same_table(run_folder, tmp_path):
    result = cavesim("replay", str(run_folder), "--trajectories", str(COUNT), "--every",
                     str(EVERY), "--out", str(tmp_path))
    assert result.returncode == 0, result.stdout + result.stderr
    ran, replayed = (pq.read_table(p / "trajectories.parquet") for p in (run_folder, tmp_path))
    assert ran.num_rows > COUNT and ran.equals(replayed, check_metadata=True)
    assert file_metadata(run_folder / "trajectories.parquet") == \
        file_metadata(tmp_path / "trajectories.parquet")


@pytest.mark.parametrize(("args", "message"), [
    (("run", "--trajectories", "0"), "argument --trajectories: expected particles in [1, "
                                     "1000000], got '0'"),
    (("run", "--trajectories", "many"), "argument --trajectories: expected particles in"),
    (("run", "--trajectories", "5", "--every", "0"), "argument --every: expected frames in "
                                                     "[1, 1000000000], got '0'"),
    (("run", "--every", "3"), "argument --every: only with --trajectories N"),
    (("replay", "tests/data/logs/vortex_portable.log", "--trajectories", "5"),
     "argument --trajectories: give --out DIR for trajectories.parquet"),
], ids=["zero", "not-a-number", "every-zero", "every-alone", "replay-without-out"])
def test_a_bad_flag_gets_one_line(args, message):
    result = cavesim(*args, timeout=60)
    assert result.returncode == 2, result.stdout + result.stderr
    assert message in result.stderr and "Traceback" not in result.stderr
    assert result.stderr.strip().count("\n") == 0
