"""The birth index follows the float64 twin's stream through births, deaths, capacity drops
and runaway drops; the tracked rows are the twin's particles. The twin keeps the GPU's
stream order, so what holds here holds for the engine (tests/gpu/test_trajectory_engine.py).

The truth is found another way than the tracker's: a particle's float32 lifetime, drawn
from the random texture, tells it apart from every other live one (asserted), and a
newborn (age 0) takes the next ids in stream order."""

from __future__ import annotations

import numpy as np
import pyarrow as pa
import pytest
from fountain import DT, fountain, steps

from cavesim.core.trajectories import BirthIndex, Selection, TrajectoryRecorder, arrow_schema
from cavesim.core.trajectories.recording import read_span, survivors
from cavesim.core.twin.system import TwinParticles, TwinSystem


class Truth:
    """Ids by lifetime bits: newborns (age 0, at the stream's end) take the next ids."""

    def __init__(self) -> None:
        self.by_lifetime: dict[int, int] = {}
        self.next_id = 0

    def follow(self, records: np.ndarray) -> np.ndarray:
        keys = records["lifetime"].view(np.uint32).tolist()
        assert len(set(keys)) == len(keys), "two live particles share a lifetime"
        ids = []
        for key, age in zip(keys, records["age"].tolist(), strict=True):
            if age == 0.0:
                self.by_lifetime[key] = self.next_id
                self.next_id += 1
            ids.append(self.by_lifetime[key])
        return np.array(ids, np.uint64)


def follow(index: BirthIndex, twin: TwinSystem) -> None:
    """One step of `index` after the twin's, reading its survivors when asked."""
    kept = survivors(twin)
    index.advance(DT, kept, read_span(twin, kept, twin.live_count - kept),
                  lambda: read_span(twin, 0, kept))


@pytest.mark.parametrize("capacity", [10_000, 60], ids=["roomy", "capacity-drops"])
def test_the_birth_index_follows_the_twin_through_births_and_deaths(capacity):
    twin = TwinSystem(fountain(capacity=capacity))
    index, truth = BirthIndex(), Truth()
    deaths = 0
    for _ in steps(twin, 300):
        kept = survivors(twin)
        deaths += len(index) - kept
        index.advance(DT, kept, read_span(twin, kept, twin.live_count - kept),
                      lambda: pytest.fail("no runaway here: no survivor should be read"))
        np.testing.assert_array_equal(index.ids, truth.follow(twin.particles.records()))
    assert deaths > 1000 and index.next_id > 1000
    if capacity == 60:
        assert twin.live_count == 60  # the capacity dropped newborns


def test_a_runaway_drop_is_found_by_matching_the_survivors():
    twin = TwinSystem(fountain())
    index, truth = BirthIndex(), Truth()
    for k in steps(twin, 60):
        if k == 30:  # the next step finds these not sane and drops them
            assert index.ambiguous_drops == 0
            twin.particles.vel[[3, 17, len(index) - 1]] = 1e9
        follow(index, twin)
        np.testing.assert_array_equal(index.ids, truth.follow(twin.particles.records()))
    assert index.ambiguous_drops == 0


def test_a_runaway_among_twins_is_counted_ambiguous():
    """Fixed lifetimes: every particle of one frame has the same age, lifetime and class."""
    twin = TwinSystem(fountain(lifetime=(0.3, 0.3)))
    index = BirthIndex()
    for k in steps(twin, 12):
        if k == 10:
            twin.particles.vel[len(index) - 2] = 1e9  # a newborn among its frame's twins
        follow(index, twin)
    assert index.ambiguous_drops == 1
    assert np.all(np.diff(index.ids.astype(np.int64)) > 0)


def test_the_rows_are_the_tracked_particles_of_the_twin():
    scene = fountain()
    twin = TwinSystem(scene)
    selection = Selection.for_run(scene, 40, 300, DT)
    tables: list[pa.Table] = []
    recorder = TrajectoryRecorder(scene, selection, 3, tables.append)
    truth = Truth()
    expected = []
    for k in steps(twin, 300):
        recorder.after_step(k, DT, twin)
        records = twin.particles.records()
        ids = truth.follow(records)
        tracked = selection.tracked(ids)
        if k % 3 == 0:  # the record's position, as the GPU holds it, and the twin's own
            held = TwinParticles.from_records(records, np.float64).position()
            expected.append((k, ids[tracked], held[tracked], twin.particles.position()[tracked],
                             twin.particles.vel[tracked]))
    rows = pa.concat_tables(tables)
    assert rows.schema == arrow_schema()
    assert selection.stride == int(300 * 300 * DT // 40)
    ids = rows["id"].to_numpy()
    assert len(np.unique(ids)) == 40 and np.all(ids % selection.stride == 0)
    at = 0
    for k, want_ids, position, exact, velocity in expected:
        n = len(want_ids)
        part = rows.slice(at, n)
        at += n
        assert part["frame"].to_pylist() == [k] * n
        np.testing.assert_array_equal(part["id"].to_numpy(), want_ids)
        got = np.column_stack([part[c].to_numpy() for c in "xyz"])
        np.testing.assert_array_equal(got, position)
        np.testing.assert_allclose(got, exact, rtol=0, atol=1e-6)
        np.testing.assert_array_equal(np.column_stack([part[c].to_numpy() for c in "uvw"]),
                                      velocity.astype(np.float32))
        assert part["time"].to_pylist() == [pytest.approx(k * DT)] * n
        assert set(part["class"].to_pylist()) <= {"drop"}
    assert at == rows.num_rows


def test_a_loaded_stream_is_held_only_if_it_is_the_one_followed():
    """A node resynced to another state (it diverged or fell behind) must drop its file."""
    twin = TwinSystem(fountain())
    index = BirthIndex()
    for _ in steps(twin, 30):
        follow(index, twin)
    records = twin.particles.records()
    assert index.holds(records)
    behind = records.copy()
    behind["age"] += np.float64(np.float32(DT))  # a frame further on
    assert not index.holds(behind) and not index.holds(records[1:])
