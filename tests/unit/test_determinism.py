"""Separate processes, each with its own GL context, given identical inputs stay identical."""

import multiprocessing
from concurrent.futures import ProcessPoolExecutor

import pytest
from replica import run_replica
from scenes import FOUNTAIN, scene_dict

FRAMES = 500
PLANE = {"kind": "plane", "friction": 0.3, "resilience": 0.4, "friction_min_speed": 0.05}
BUSY = scene_dict(integrator="rk4", capacity=6000, damping=0.1, collision=PLANE, emitters=[
    FOUNTAIN, dict(FOUNTAIN, name="dust", particle_class="dust", rate=2500.0,
                   position=[1.0, -1.0, 0.3])])
OVERFLOWING = dict(BUSY, simulation=dict(BUSY["simulation"], capacity=1500))
pytestmark = pytest.mark.xdist_group("determinism")  # one set of runs, on one worker


def run_all(jobs):
    with ProcessPoolExecutor(max_workers=2,
                             mp_context=multiprocessing.get_context("spawn")) as pool:
        return list(pool.map(run_replica, *zip(*jobs, strict=True)))


@pytest.fixture(scope="module")
def runs():
    reseeded = dict(BUSY, simulation=dict(BUSY["simulation"], seed=99))
    names = ("a", "b", "other_matrix", "other_seed", "full_a", "full_b")
    jobs = [(BUSY, FRAMES, 1), (BUSY, FRAMES, 1), (BUSY, 50, 2), (reseeded, 50, 1),
            (OVERFLOWING, 200, 5), (OVERFLOWING, 200, 5)]
    return dict(zip(names, run_all(jobs), strict=True))


@pytest.mark.slow
def test_two_contexts_hold_identical_bytes_for_500_frames(runs):
    a, b = runs["a"], runs["b"]
    assert a["gl_error"] == b["gl_error"] == "GL_NO_ERROR"
    assert a["digests"] == b["digests"]
    assert a["state_sha256"] == b["state_sha256"]
    assert max(a["counts"]) > 2000, "the run should be busy enough to mean something"


@pytest.mark.slow
def test_another_matrix_or_seed_diverges_at_once(runs):
    for other in ("other_matrix", "other_seed"):
        assert runs[other]["digests"][0] != runs["a"]["digests"][0]
        # before the first lifetimes run out, the counts depend on the rates alone
        assert runs[other]["counts"][:25] == runs["a"]["counts"][:25]


@pytest.mark.slow
def test_capacity_overflow_is_identical_on_two_contexts(runs):
    a, b = runs["full_a"], runs["full_b"]
    assert max(a["counts"]) == 1500
    assert a["digests"] == b["digests"] and a["state_sha256"] == b["state_sha256"]
