"""The counter table (cavesim/core/counters.py): its rows are well formed, each scene counts
the rows its features have, the twins compute each row from what a step knows, and a row's
notice says what it counted."""

import dataclasses

import numpy as np
import pytest
from scenes import FOUNTAIN, SMOKE, scene_dict

from cavesim.core.counters import (
    BY_ID,
    BY_NAME,
    COUNTERS,
    MAX_ID,
    Combine,
    Keep,
    TwinStep,
    counted_rows,
    entries,
    twin_counts,
    widths,
)
from cavesim.core.features import grid_flow
from cavesim.core.features.registry import IDS
from cavesim.core.features.rules import evaluate
from cavesim.core.scene import load_scene, parse_scene
from cavesim.core.substeps import SubstepCounts
from cavesim.core.twin.system import TwinSystem
from cavesim.gpu.engine.programs import physics_defines

BROWNOUT = "config/scenes/brownout.toml"


def smoky(**simulation):
    data = scene_dict(integrator="rk4", emitters=[FOUNTAIN], capacity=300)
    data["particle_class"] = [*data["particle_class"], dict(SMOKE)]
    data["simulation"] |= simulation
    return parse_scene(data, name="smoky")


def test_rows_have_stable_unique_ids_and_names_and_keep_what_their_kind_allows():
    assert [row.id for row in COUNTERS] == [1, 2, 3, 4, 5, 6, 7]  # wire tags: never renumbered
    assert len(BY_NAME) == len(BY_ID) == len(COUNTERS)
    for row in COUNTERS:
        assert 1 <= row.id <= MAX_ID and row.keeps
        assert row.events or Keep.TOTAL not in row.keeps
        assert row.notice is None or row.events
    assert BY_NAME["most_substeps"].combine is Combine.MAX
    assert BY_NAME["capacity_drops"].combine is Combine.COPIED
    assert not BY_NAME["capacity_drops"].in_pass and BY_NAME["domain_exits"].per_class


def test_a_row_the_pass_counts_needs_the_defines_its_scenes_have():
    """`needs` is `counted` in the particle pass's terms: a grid's, RK45 tracers'."""
    assert BY_NAME["domain_exits"].needs == grid_flow.GRID
    for scene in (smoky(), smoky(tracer_method="rk45"), load_scene(BROWNOUT)):
        values = {**IDS, **physics_defines(scene)}
        for row in COUNTERS:
            if row.in_pass:
                assert evaluate(row.needs, values) == row.counted(scene), (scene.name, row.name)


def test_a_scene_counts_the_rows_its_features_have():
    names = [row.name for row in counted_rows(smoky(tracer_method="rk45"))]
    assert names == ["domain_exits", "capacity_drops", "tracers_stepped", "substeps_taken",
                     "substeps_retaken", "most_substeps"]
    assert [row.name for row in counted_rows(smoky())] == ["domain_exits", "capacity_drops"]
    assert [row.name for row in counted_rows(load_scene(BROWNOUT))] == ["capacity_drops",
                                                                        "ground_deposits"]
    assert widths(smoky()) == {1: 3, 2: 1}  # a value per class: sand, dust, smoke


def test_the_twins_compute_each_row_from_what_their_step_knows():
    twin = TwinSystem(smoky(tracer_method="rk45"))
    inside, outside = (0.0, 0.0, 1.0), (9.0, 0.0, 1.0)  # the vortex's box: +-4 m, 0..4 m
    start = np.array([inside, inside, outside, inside, inside])
    end = np.array([outside, outside, outside, outside, inside])
    step = TwinStep(twin, np.array([2, 0, 2, 7, 1], np.uint8), start, end,
                    np.array([True, True, True, True, True]),
                    np.array([True, False, True, True, True]), SubstepCounts(10, 17, 4, 3),
                    emitted=50, live=34)
    counts = twin_counts(twin.scene, step)
    # class 7 counts as the last, as on the GPU; a step that started outside is no exit
    assert counts == {"domain_exits": (1, 0, 2),
                      "capacity_drops": (20,), "tracers_stepped": (10,),
                      "substeps_taken": (17,), "substeps_retaken": (4,), "most_substeps": (3,)}
    insane = dataclasses.replace(step, sane=np.array([True, True, True, False, True]))
    assert twin_counts(twin.scene, insane)["domain_exits"] == (1, 0, 1)  # a runaway is no exit
    assert entries(counts) == ((1, (1, 0, 2)), (2, (20,)), (3, (10,)), (4, (17,)), (5, (4,)),
                               (6, (3,)))
    assert entries({"most_substeps": (2,), "domain_exits": (0, 1)}) == ((1, (0, 1)),
                                                                         (6, (2,)))


@pytest.mark.parametrize(("name", "values", "line"), [
    ("domain_exits", (0, 3, 1), "frame 4: particles left the field's box [-4.0, -4.0, 0.0] .. "
     "[4.0, 4.0, 4.0] (3 dust, 1 smoke); beyond it the flow is the nearest boundary node's "
     "(out_of_domain), not the field's. report.json counts every frame's "
     "(counters.domain_exits)"),
    ("capacity_drops", (1234,), "capacity full: 1,234 new particles dropped at frame 4 (the "
     "scene holds 300); report.json counts every frame's (counters.capacity_drops)"),
])
def test_a_rows_notice_says_what_it_counted_and_where_report_json_keeps_it(name, values, line):
    assert BY_NAME[name].notice(smoky(), 4, values) == line
