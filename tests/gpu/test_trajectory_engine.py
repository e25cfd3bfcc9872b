"""trajectories.parquet from the GL engine equals, row for row, what the float64 twin's
recorder writes (tests/unit/test_trajectory_identity.py holds the twin's rows to its
particles): the same ids every frame, through deaths, capacity drops and a runaway drop,
on each engine path; positions to the float32 state's precision."""

import dataclasses

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from fountain import DT, fountain, frames

from cavesim.core.scene import Engine
from cavesim.core.trajectories import (
    FILE_NAME,
    Selection,
    TrajectoryRecorder,
    TrajectoryRecording,
    TrajectoryRequest,
    arrow_schema,
)
from cavesim.core.twin.system import TwinSystem
from cavesim.gpu.engine import ParticleSystem

FRAMES, EVERY, COUNT = 150, 2, 30
RUNAWAY_AT = 100  # this frame's step drops a particle sent past the speed limit


def fountain_on(engine: Engine):
    """Full from about frame 60: newborns are dropped at the capacity."""
    return dataclasses.replace(fountain(rate=600.0, capacity=150), engine=engine)


@pytest.mark.parametrize("engine", [Engine.GS_TF, Engine.COMPUTE])
def test_the_engine_writes_the_twins_rows(ctx, tmp_path, engine):
    scene = fountain_on(engine)
    gpu, twin = ParticleSystem(ctx, scene), TwinSystem(scene)
    recording = TrajectoryRecording(tmp_path, scene, TrajectoryRequest(COUNT, EVERY, FRAMES, DT))
    twin_rows: list[pa.Table] = []
    twin_recorder = TrajectoryRecorder(scene, Selection.for_run(scene, COUNT, FRAMES, DT),
                                       EVERY, twin_rows.append)
    dropped = 0
    for k, frame in frames(scene, FRAMES, seed=3):
        if k == RUNAWAY_AT:
            for system in (gpu, twin):  # each its own records: lifetimes differ by an ulp
                records = system.read_particles() if system is gpu else twin.particles.records()
                records["vel"][5] = 1e9
                system.write_particles(records)
        gpu.step(frame)
        twin.step(frame)
        dropped += gpu.dropped()
        recording.after_step(k, DT, gpu)
        twin_recorder.after_step(k, DT, twin)
    path = recording.finish()
    gpu.release()
    assert path == tmp_path / FILE_NAME and dropped > 0
    table = pq.read_table(path)
    twin_table = pa.concat_tables(twin_rows)
    assert table.schema.remove_metadata() == arrow_schema()
    # the capacity keeps births below the nominal rate: fewer than COUNT get born
    assert table.num_rows > 100 and 20 <= len(set(table["id"].to_pylist())) <= COUNT
    for exact in ("frame", "time", "id", "class"):
        assert table[exact].equals(twin_table[exact]), exact
    for close in "xyzuvw":
        np.testing.assert_allclose(table[close].to_numpy(), twin_table[close].to_numpy(),
                                   rtol=1e-5, atol=1e-4, err_msg=close)
    metadata = pq.read_metadata(path).metadata
    assert metadata[b"ambiguous_drops"] == b"0" and metadata[b"frames"] == str(FRAMES).encode()
