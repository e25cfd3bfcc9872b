"""docs/trajectories.md says what the file holds: its columns table is the writer's
(`COLUMNS`), it names every metadata key, and its loading example runs as written on a file
the twin's recorder writes."""

import os
import re
import subprocess
import sys
from pathlib import Path

from fountain import DT, fountain, steps

from cavesim.core.trajectories import COLUMNS, TrajectoryRecording, TrajectoryRequest
from cavesim.core.trajectories.parquet_file import METADATA_AT_CLOSE, METADATA_AT_OPEN
from cavesim.core.twin.system import TwinSystem

ROOT = Path(__file__).parents[2]
PAGE = ROOT / "docs/trajectories.md"


def test_the_columns_table_is_the_writers():
    rows = re.findall(r"^\| `(\w+)` \| (\w+) \| ([^|]*) \| ([^|]*) \|$", PAGE.read_text(), re.M)
    assert [(name, kind, unit.strip(), meaning.strip()) for name, kind, unit, meaning in rows] \
        == [(c.name, c.type_name, c.unit, c.meaning) for c in COLUMNS]


def test_every_metadata_key_is_named():
    text = PAGE.read_text()
    assert [key for key in (*METADATA_AT_OPEN, *METADATA_AT_CLOSE) if f"`{key}`" not in text] \
        == []


def test_the_loading_example_runs(tmp_path):
    folder = tmp_path / "out" / "traj"
    folder.mkdir(parents=True)
    scene = fountain()
    twin = TwinSystem(scene)
    recording = TrajectoryRecording(folder, scene, TrajectoryRequest(20, 2, 60, DT))
    for k in steps(twin, 60):
        recording.after_step(k, DT, twin)
    recording.finish()
    (example,) = re.findall(r"```python\n(.*?)```", PAGE.read_text(), re.S)
    result = subprocess.run([sys.executable, "-c", example], cwd=tmp_path, capture_output=True,
                            text=True, timeout=120, env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert result.returncode == 0, result.stderr
    assert result.stdout.split()[-1] == str(int(60 * 300 * DT // 20))  # the stride
