"""The adaptive tracer method, RK45: Dormand-Prince 5(4) on binary substeps of the frame
(cavesim/core/substeps.py), in the float64 twin against the solid-body vortex in closed
form; where in a time series its substeps take the flow; and how a scene asks for it."""

from __future__ import annotations

import copy
import math

import numpy as np
import pytest
from scenes import SMOKE, scene_dict

from cavesim.core.errors import SceneError
from cavesim.core.fields.snapshot_time import FieldTime, places_in_step
from cavesim.core.operations import PORTABLE_OPERATIONS, REFERENCE_OPERATIONS
from cavesim.core.scene import TracerMethod, parse_scene
from cavesim.core.scene.digest import scene_digest
from cavesim.core.substeps import MAX_LEVEL, UNITS, SubstepCounts
from cavesim.core.twin.forces import ForceModel
from cavesim.core.twin.tracers import rk45
from cavesim.tools.numerics.solid_body import disk, rotated, solid_body

FRAME = 0.5  # s: a long frame, so that the tolerance divides it
FRAMES = 4
TRACERS = 100


def vortex_run(tolerance: float) -> tuple[float, list[SubstepCounts]]:
    """RMS error after FRAMES frames of RK45 at `tolerance`, and each frame's counts."""
    forces = ForceModel(gravity=None, damping=None, inv_tau=None, flow=solid_body)
    start = p = disk(TRACERS)
    counts: list[SubstepCounts] = []
    for _ in range(FRAMES):
        p, v = rk45(p, FRAME, forces, tolerance, counts.append)
    np.testing.assert_array_equal(v, solid_body(p))  # the last substep's flow: the end's
    error = p - rotated(start, FRAMES * FRAME)
    return float(np.sqrt(np.mean(np.sum(error**2, axis=1)))), counts


def test_a_tighter_tolerance_takes_more_substeps_and_errs_less():
    runs = {tolerance: vortex_run(tolerance) for tolerance in (math.inf, 1e-5, 1e-8, 1e-10)}
    errors = [error for error, _ in runs.values()]
    taken = [sum(c.taken for c in counts) for _, counts in runs.values()]
    assert errors == sorted(errors, reverse=True) and errors[-1] < 1e-9, errors
    assert taken == sorted(taken) and taken[0] == FRAMES * TRACERS and taken[-1] > 2 * taken[0]
    # each substep's estimate is held to the tolerance: the error over the run stays
    # within the tolerance times the substeps one tracer took, with room for the estimate
    for tolerance, (error, counts) in runs.items():
        if tolerance < math.inf:
            assert error < 10 * tolerance * sum(c.most for c in counts), (tolerance, error)


def test_without_a_tolerance_each_frame_is_one_dormand_prince_step():
    _, counts = vortex_run(math.inf)
    assert counts == [SubstepCounts(TRACERS, TRACERS, 0, 1)] * FRAMES


def test_a_tolerance_no_substep_meets_ends_at_the_smallest_substep():
    """Six refusals take the first substep down to h / 64, which is always taken: the frame
    still ends at h, in UNITS substeps, and never loops on."""
    _, counts = vortex_run(1e-300)
    assert counts[0] == SubstepCounts(TRACERS, TRACERS * UNITS, TRACERS * MAX_LEVEL, UNITS)


def test_a_substep_grows_again_where_the_flow_allows():
    """A tracer far out in the vortex needs small substeps, one near its centre none: with
    one frame the second starts at a level of its own and grows back."""
    forces = ForceModel(gravity=None, damping=None, inv_tau=None, flow=solid_body)
    p = np.array([[0.0, 1e-4, 1.0], [0.0, 0.8, 1.0]])
    counts: list[SubstepCounts] = []
    rk45(p, 2.0, forces, 1e-9, counts.append)
    (frame,) = counts
    assert frame.most < UNITS and frame.taken > frame.most + 1 and frame.retaken > 0


@pytest.mark.parametrize("ops", [REFERENCE_OPERATIONS, PORTABLE_OPERATIONS],
                         ids=["float64", "portable"])
def test_substeps_find_a_series_where_each_stage_does_and_between_them(ops):
    """Pairs (2, 2, 3) with weights (1/4, 3/4, 1/4): the step's first half lies in interval
    2, its second crosses snapshot 3 at three quarters of the step."""
    dtype = np.float64 if ops is REFERENCE_OPERATIONS else np.float32
    field_time = FieldTime((2, 2, 3), (0.25, 0.75, 0.25))
    fraction = np.array([0.0, 0.25, 0.5, 0.75, 0.875, 1.0], dtype=dtype)
    pairs, weights = places_in_step(field_time, fraction, 9, ops)
    assert pairs.tolist() == [2, 2, 2, 3, 3, 3]
    assert weights.tolist() == [0.25, 0.5, 0.75, 0.0, 0.125, 0.25]
    after_the_last = FieldTime((7, 7, 7), (1.0, 1.0, 1.0))  # the last snapshot holds
    pairs, weights = places_in_step(after_the_last, fraction, 9, ops)
    assert pairs.tolist() == [7] * 6 and weights.tolist() == [1.0] * 6


def smoky(**simulation) -> dict:
    data = copy.deepcopy(scene_dict(integrator="rk4"))
    data["particle_class"].append(dict(SMOKE))
    data["simulation"] |= simulation
    return data


def test_a_scene_steps_its_tracers_by_rk45_where_it_says_so():
    assert parse_scene(smoky(), name="s").method_for_tracers is TracerMethod.RK4
    scene = parse_scene(smoky(tracer_method="rk45", tracer_tolerance=1e-8), name="s")
    assert scene.method_for_tracers is TracerMethod.RK45 and scene.tracer_tolerance == 1e-8


def test_the_tracer_keys_are_refused_in_one_line_where_they_make_no_sense():
    for data, needles in (
            (scene_dict(integrator="rk4") | {"simulation": {
                **scene_dict()["simulation"], "tracer_method": "rk45"}},
             ("simulation.tracer_method", 'motion = "tracer"')),
            (smoky(tracer_method="rk5"), ("simulation.tracer_method", "'rk45'")),
            (smoky(tracer_tolerance=0.0), ("simulation.tracer_tolerance", ">= 1e-10"))):
        with pytest.raises(SceneError) as caught:
            parse_scene(data, name="bad")
        message = str(caught.value)
        assert "\n" not in message and all(n in message for n in needles), message


def test_the_default_tolerance_leaves_a_scenes_digest_as_it_was():
    plain = parse_scene(smoky(), name="s")
    assert scene_digest(parse_scene(smoky(tracer_tolerance=1e-6), name="s")) == \
        scene_digest(plain)
    assert scene_digest(parse_scene(smoky(tracer_tolerance=1e-7), name="s")) != \
        scene_digest(plain)
    assert scene_digest(parse_scene(smoky(tracer_method="rk45"), name="s")) != \
        scene_digest(plain)
