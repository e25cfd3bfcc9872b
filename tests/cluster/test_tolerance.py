"""The mixed-hardware tolerance mode: drift samples and their distances, the rules of the
mode as pure functions, the master's whole loop over walls in memory (tests/support/memory_walls.py)
whose drift samples a nudge moves, a node's sample and drift faults on the GPU, and the
command line's flags."""

import json
import math
from pathlib import Path

import numpy as np
import pytest
from memory_walls import MemoryLink
from scenes import FOUNTAIN, make_scene

from cavesim.core.drift import (
    MAX_SAMPLE,
    NO_DRIFT,
    DriftSample,
    measure_drift,
    sample_indices,
)
from cavesim.core.frame_cost import NO_COST
from cavesim.core.wire import ReportMessage
from cavesim.gpu.engine import FrameInput, ParticleSystem
from cavesim.tools.reports.run_tables import mode_rows
from nodes import cli
from nodes.arguments import USAGE_ERROR
from nodes.commands.run import RunPlan
from nodes.master.budgets import BREACH, WINDOW, Budget
from nodes.master.process import MasterConfig, run_master
from nodes.master.tolerance import (
    BIT_EXACT,
    MIXED_HARDWARE,
    Tolerance,
    ToleranceMode,
    judge,
)
from nodes.mixed_hardware import node_sample_from, tolerance_from
from nodes.wall import drift_sample as node_drift

TWO_NODES = {"front": ("front",), "left": ("left",)}  # a plan's nodes and their walls

MINIMAL = Path(__file__).parents[2] / "config" / "scenes" / "minimal.toml"
WALLS = ("front", "left", "right")
SMALL, LARGE = 1e-6, 0.5  # m: a nudge within the default tolerance (2 mm), and one beyond


def sample(x: float, count: int = 4, v: float = 0.0) -> DriftSample:
    positions = np.zeros((count, 3))
    positions[:, 0] = x
    velocities = np.zeros((count, 3))
    velocities[:, 1] = v
    return DriftSample.of(positions, velocities)


def report(wall, digest, x=0.0, particles=4, v=0.0, with_sample=True, frame=1):
    return ReportMessage(frame, wall, digest * 32, particles, 0, NO_COST,
                         sample=sample(x, min(particles, 4), v) if with_sample else None)


TOLERANCE = Tolerance("front", resync_every=10, sample=4, position=1e-3, velocity=1e-2)


# -- samples and distances ------------------------------------------------------------------

@pytest.mark.parametrize("live, size", [(0, 4), (3, 4), (4, 4), (10, 4), (1000, 256),
                                        (10**6, MAX_SAMPLE)])
def test_sample_indices_are_evenly_spread_distinct_and_live(live, size):
    indices = sample_indices(live, size)
    assert len(indices) == min(live, size)
    assert len(set(indices.tolist())) == len(indices)
    if len(indices):
        assert indices[0] == 0 and indices[-1] < live
        gaps = np.diff(indices)
        assert gaps.min() >= live // size and gaps.max() <= -(-live // size)


def test_drift_is_the_max_and_rms_of_the_distances():
    ours = DriftSample.of(np.array([[3.0, 4.0, 0.0], [0.0, 0.0, 0.0]]), np.zeros((2, 3)))
    theirs = DriftSample.of(np.zeros((2, 3)), np.array([[0.0, 0.0, 1.0], [0.0, 0.0, 0.0]]))
    drift = measure_drift(ours, 2, theirs, 2)
    assert drift.position_max == 5.0 and drift.position_rms == pytest.approx(math.sqrt(12.5))
    assert drift.velocity_max == 1.0 and drift.velocity_rms == pytest.approx(math.sqrt(0.5))
    assert not drift.exceeds(5.0, 1.0) and drift.exceeds(4.9, 1.0) and drift.exceeds(5.0, 0.9)


def test_other_live_counts_or_a_nan_breach_any_tolerance():
    counts = measure_drift(sample(0.0), 5, sample(0.0), 4)
    assert counts.counts_differ and counts.exceeds(1e3, 1e3)
    assert counts.to_json()["position_max_m"] is None  # JSON has no infinity
    nan = measure_drift(sample(math.nan), 4, sample(0.0), 4)
    assert nan.position_max == math.inf and nan.exceeds(1e3, 1e3)


def test_a_sample_is_whole_records_within_the_limit():
    with pytest.raises(ValueError, match="whole 24-byte records"):
        DriftSample(bytes(25))
    with pytest.raises(ValueError, match="0 to 1024"):
        DriftSample(bytes(24 * (MAX_SAMPLE + 1)))


@pytest.mark.parametrize("options, match", [
    ({"resync_every": 0}, "resync_every"), ({"sample": MAX_SAMPLE + 1}, "sample"),
    ({"position": 0.0}, "position"), ({"velocity": math.inf}, "velocity")])
def test_settings_out_of_range_are_refused(options, match):
    with pytest.raises(ValueError, match=match):
        Tolerance("front", **options)


# -- the rules --------------------------------------------------------------------------------

def test_a_drift_within_tolerance_is_measured_but_not_named():
    reports = {"front": report("front", "a"), "left": report("left", "b", x=5e-4),
               "right": report("right", "a")}
    judgement = judge(3, WALLS, reports, TOLERANCE)
    assert judgement.vote.odd == () and judgement.vote.source == "front"
    assert judgement.drifts["left"].position_max == pytest.approx(5e-4)
    assert judgement.drifts["right"] is NO_DRIFT  # the authority's bits: nothing to measure


@pytest.mark.parametrize("left", [report("left", "b", x=2e-3), report("left", "b", v=0.1),
                                  report("left", "b", particles=5)],
                         ids=["position", "velocity", "live-count"])
def test_a_breach_names_the_node_and_resyncs_it_from_the_authority(left):
    reports = {"front": report("front", "a"), "left": left, "right": report("right", "c")}
    vote = judge(3, WALLS, reports, TOLERANCE).vote
    assert (vote.named, vote.odd, vote.source, vote.agreed) == (("left",), ("left",), "front",
                                                                "a" * 32)


def test_the_periodic_resync_takes_every_node_whose_bits_differ_without_naming_it():
    reports = {"front": report("front", "a"), "left": report("left", "b", x=1e-4),
               "right": report("right", "a")}
    assert judge(9, WALLS, reports, TOLERANCE).vote.odd == ()
    judgement = judge(10, WALLS, reports, TOLERANCE)
    assert judgement.periodic == ("left",) and judgement.vote.odd == ("left",)
    assert judgement.vote.named == ()
    assert judge(10, WALLS, reports, TOLERANCE, compare=False).vote.odd == ("left",)


def test_two_walls_name_only_the_one_that_is_not_the_authority():
    reports = {"front": report("front", "a"), "left": report("left", "b", x=1.0)}
    assert judge(3, ("front", "left"), reports, TOLERANCE).vote.named == ("left",)


def test_the_first_member_acts_while_the_authority_is_out():
    reports = {"left": report("left", "b"), "right": report("right", "c", x=1.0)}
    vote = judge(3, ("left", "right"), reports, TOLERANCE).vote
    assert (vote.source, vote.named) == ("left", ("right",))


def test_a_report_without_a_sample_or_of_another_size_is_refused_with_a_hint():
    reports = {"front": report("front", "a"), "left": report("left", "b", with_sample=False),
               "right": report("right", "a", with_sample=False)}  # its bits: not needed
    judgement = judge(3, WALLS, reports, TOLERANCE)
    assert judgement.vote.odd == () and set(judgement.refused) == {"left"}
    assert "left's report carries no drift sample" in judgement.refused["left"]
    assert "--mixed-hardware" in judgement.refused["left"]
    reports["left"] = report("left", "b", particles=4)
    refused = judge(3, WALLS, reports, Tolerance("front", sample=3)).refused
    assert list(refused) == ["front"]  # the authority's: no one can be measured against it
    assert "front sampled 4 of its 4 live records, the master expects 3 (--drift-sample 3)" \
        in refused["front"]


def test_the_authority_must_be_a_wall():
    with pytest.raises(ValueError, match="authority 'ceiling' is not one of the walls"):
        ToleranceMode(Tolerance("ceiling"), WALLS)


# -- the master's loop ------------------------------------------------------------------------

def run(link, frames=30, tolerance=None, **options):
    config = MasterConfig(tuple(link.walls), MINIMAL, frames, "memory", barrier_timeout=0.05,
                          tolerance=tolerance, **options)
    return run_master(config, link)


def drift_of(summary, wall):
    drift = summary["tolerance"]["drift"][wall]
    return dict(zip(drift["frames"], drift["position_max_m"], strict=True))


def test_a_small_drift_is_tolerated_and_reported_a_large_one_is_resynced_from_the_authority():
    link = MemoryLink(WALLS, sample=4)
    link.walls["left"].nudge_at.update({3: SMALL, 15: LARGE})
    record = run(link, tolerance=Tolerance("right", resync_every=10, sample=4))
    summary = json.loads(json.dumps(record.summary()))  # what report.json holds
    assert summary["mode"] == MIXED_HARDWARE
    drift = drift_of(summary, "left")
    assert drift[2] == 0.0 and drift[3] == pytest.approx(SMALL) and drift[9] == drift[3]
    assert drift[11] == 0.0 and drift[15] == LARGE and drift[16] == 0.0  # resynced at 10
    (divergence,) = record.divergences  # the breach, and nothing at the small drift
    assert (divergence.frame, divergence.nodes) == (15, ("left",))
    resyncs = [(r.frame, r.node, r.source, r.ok) for r in record.resyncs]
    assert resyncs == [(10, "left", "right", True), (15, "left", "right", True)]
    tolerance = summary["tolerance"]
    assert tolerance["periodic_resyncs"] == 1 and tolerance["breach_total"] == 1
    (breach,) = tolerance["breaches"]
    assert (breach["frame"], breach["node"], breach["authority"]) == (15, "left", "right")
    assert breach["position_max_m"] == pytest.approx(LARGE, rel=1e-2)
    assert tolerance["authority"] == "right" and tolerance["resync_every_frames"] == 10
    assert set(tolerance["drift"]) == {"front", "left"}
    assert tolerance["drift"]["front"]["bit_equal"] == 30


def test_reports_without_a_sample_are_counted_and_never_end_the_run():
    link = MemoryLink(WALLS, sample=4)
    for wall in ("left", "right"):
        link.walls[wall].nudge_at[2] = SMALL  # bits not the authority's: a sample is needed
    link.walls["left"].unsampled_at.update({3, 4, 9})  # as a forged report would be
    link.walls["right"].unsampled_at.add(5)
    link.walls["front"].unsampled_at.add(7)  # the authority's: no one can be measured
    record = run(link, tolerance=Tolerance("front", sample=4))
    tolerance = record.summary()["tolerance"]
    assert tolerance["refused_samples"] == {"front": 1, "left": 3, "right": 1}
    assert tolerance["drift"]["left"]["comparisons"] == 30 - 3 - 1
    assert record.frames == 30 and record.final.all_walls_in  # bits differ: no "agree"
    assert record.divergences.total == 0 and not record.losses


def test_a_wall_that_keeps_breaching_is_given_up_not_resynced_forever():
    link = MemoryLink(WALLS, sample=4)
    link.walls["left"].nudge_at.update({k: LARGE for k in range(3, 300)})
    record = run(link, frames=300, tolerance=Tolerance("front", sample=4),
                 breach_budget=Budget(4, WINDOW))
    left_resyncs = [r.frame for r in record.resyncs if r.node == "left"]
    assert left_resyncs == [3, 4, 5, 6]  # the budget's 4, then the 5th breach gives it up
    (loss,) = record.losses
    assert (loss.frame, loss.node, loss.detected_by) == (7, "left", "breach-budget")
    summary = record.summary()
    assert summary["tolerance"]["breach_total"] == 5
    assert summary["budgets"][BREACH] == {
        "most": 4, "window_frames": WINDOW, "given_up_total": 1,
        "given_up": [{"frame": 7, "node": "left", "events": 5, "window_frames": WINDOW}]}
    assert record.frames == 300 and record.final.lost == ("left",) and record.final.agree


def test_breaches_further_apart_than_the_window_stay_within_the_budget():
    link = MemoryLink(WALLS, sample=4)
    link.walls["left"].nudge_at.update({k: LARGE for k in range(3, 40, 10)})
    record = run(link, frames=40, tolerance=Tolerance("front", sample=4),
                 breach_budget=Budget(1, 10))
    assert [r.frame for r in record.resyncs] == [3, 13, 23, 33] and not record.losses


def test_the_bit_exact_mode_names_the_small_drift_at_once():
    link = MemoryLink(WALLS)
    link.walls["left"].nudge_at[3] = SMALL
    record = run(link)
    (divergence,) = record.divergences
    assert (divergence.frame, divergence.nodes) == (3, ("left",))
    summary = record.summary()
    assert summary["mode"] == BIT_EXACT and "tolerance" not in summary


def test_a_wall_lost_and_back_follows_the_acting_authority():
    link = MemoryLink(WALLS, sample=4)

    def fault(k):
        if k == 5:
            link.go_down("front")
        elif k == 12:
            link.come_up("front")

    config = MasterConfig(WALLS, MINIMAL, 30, "memory", barrier_timeout=0.05,
                          tolerance=Tolerance("front", sample=4))
    record = run_master(config, link, before_frame=fault)
    handovers = record.summary()["tolerance"]["authority_handovers"]
    assert [(h["from"], h["to"]) for h in handovers] == [("front", "left"), ("left", "front")]
    (join,) = record.joins
    assert join.node == "front" and record.final.agree and record.final.all_walls_in


# -- a node's side, on the GPU ----------------------------------------------------------------

@pytest.fixture
def fountain(ctx):
    system = ParticleSystem(ctx, make_scene(emitters=[FOUNTAIN], capacity=4000, seed=3))
    rng = np.random.default_rng(3)
    for _ in range(40):
        system.step(FrameInput(1 / 60, np.array([[1, rng.integers(9), rng.integers(64)],
                                                 [0, 1, rng.integers(64)], [0, 0, 1]])))
    yield system
    system.release()


@pytest.mark.parametrize("size", [7, 1024], ids=["record-by-record", "whole-stream"])
def test_a_nodes_sample_holds_the_records_sample_indices_names(fountain, size):
    particles = fountain.read_particles()
    assert len(particles) > node_drift.WHOLE_STREAM_READ * 7
    expected = particles[sample_indices(len(particles), size)]
    got = node_drift.read_drift_sample(fountain, size).array()
    assert np.array_equal(got["pos"], expected["pos"])
    assert np.array_equal(got["vel"], expected["vel"])


def test_jitter_changes_the_bits_but_hardly_the_positions_and_shove_breaches(fountain):
    before = fountain.checksum()
    held = node_drift.read_drift_sample(fountain, 64)
    node_drift.jitter(fountain)
    after = fountain.checksum()
    drift = measure_drift(node_drift.read_drift_sample(fountain, 64), after.particles, held,
                          before.particles)
    assert after.digest != before.digest and after.particles == before.particles
    assert 0 < drift.position_max < 1e-5 and drift.velocity_max == 0.0
    assert not drift.exceeds(TOLERANCE.position, TOLERANCE.velocity)
    node_drift.shove(fountain)
    drift = measure_drift(node_drift.read_drift_sample(fountain, 64), after.particles, held,
                          before.particles)
    assert drift.position_max == pytest.approx(node_drift.SHOVE_METRES, rel=1e-3)


# -- the command line --------------------------------------------------------------------------

@pytest.mark.parametrize("args, message", [
    (["run", "--walls", "2", "--mixed-hardware", "--authority", "ceiling"],
     "cavesim run: error: argument --authority: 'ceiling' is not a wall of this run; choose "
     "one of front, left"),
    (["master", "--walls", "front,left", "--mixed-hardware", "--authority", "x"],
     "cavesim master: error: argument --authority: 'x' is not a wall of this run"),
    (["run", "--walls", "2", "--authority", "front"],
     "cavesim run: error: argument --authority: only with --mixed-hardware"),
    (["master", "--walls", "front", "--position-tolerance", "1"],
     "cavesim master: error: argument --position-tolerance: only with --mixed-hardware"),
    (["node", "--wall", "front", "--drift-sample", "8"],
     "cavesim node: error: argument --drift-sample: only with --mixed-hardware"),
    (["run", "--mixed-hardware", "--resync-every", "0"],
     "argument --resync-every: expected frames in [1, 100000], got '0'"),
    (["master", "--walls", "front", "--mixed-hardware", "--drift-sample", "2000"],
     "argument --drift-sample: expected records in [1, 1024], got '2000'"),
    (["run", "--mixed-hardware", "--breach-budget", "0"],
     "argument --breach-budget: expected breaches in [1, 10000], got '0'"),
    (["run", "--mixed-hardware", "--velocity-tolerance", "nan"],
     "argument --velocity-tolerance: expected m/s in"),
])
def test_bad_mixed_hardware_flags_are_one_line_usage_errors(args, message, capsys):
    assert cli.main(args) == USAGE_ERROR
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert message in line


def test_the_master_takes_the_first_wall_as_authority_and_the_defaults():
    args = cli.build_parser().parse_args(["master", "--walls", "left,front", "--mixed-hardware",
                                          "--velocity-tolerance", "0.5"])
    assert tolerance_from(args, args.walls, "master") == Tolerance("left", velocity=0.5)
    plain = cli.build_parser().parse_args(["master", "--walls", "left,front"])
    assert tolerance_from(plain, plain.walls, "master") is None


def test_run_gives_the_master_the_tolerance_and_every_node_the_matching_flags(tmp_path):
    plan = RunPlan(TWO_NODES, MINIMAL, 10, tmp_path, tolerance=Tolerance("left",
                                                                                 sample=8))
    cluster = plan.cluster()
    assert cluster.master.tolerance == plan.tolerance
    for args in cluster.node_args.values():
        parsed = cli.build_parser().parse_args(["node", "--wall", "front", *args])
        assert node_sample_from(parsed, "node") == 8
    bit_exact = RunPlan(TWO_NODES, MINIMAL, 10, tmp_path).cluster()
    assert bit_exact.master.tolerance is None
    assert bit_exact.node_args == {"front": (), "left": ()}


def test_the_summary_names_the_mode_and_its_settings():
    link = MemoryLink(WALLS, sample=4)
    link.walls["left"].nudge_at[3] = SMALL
    summary = run(link, frames=5, tolerance=Tolerance("front", sample=4)).summary()
    rows = dict(mode_rows(summary))
    assert rows["mode"] == "mixed-hardware tolerance (authority front, native arithmetic)"
    assert rows["resync every / sample"] == "120 frames / 4 records"
    assert rows["tolerance (position / velocity)"] == "0.002 m / 0.01 m/s"
    assert rows["breaches / periodic resyncs"] == "0 / 0"
    assert rows["worst drift (position / velocity)"] == "1e-06 m / 0 m/s"
    assert mode_rows(run(MemoryLink(WALLS), frames=2).summary()) == [
        ("mode", "bit-exact (native arithmetic)")]


def test_the_summary_names_the_scenes_arithmetic(tmp_path):
    """Bit-exact across mixed GPUs needs portable arithmetic: the report says which ran."""
    portable = tmp_path / "portable.toml"
    portable.write_text(MINIMAL.read_text().replace("[simulation]",
                                                    '[simulation]\narithmetic = "portable"'))
    config = MasterConfig(WALLS, portable, 2, "memory", barrier_timeout=0.05)
    summary = run_master(config, MemoryLink(WALLS, scene=portable)).summary()
    assert summary["arithmetic"] == "portable"
    assert dict(mode_rows(summary))["mode"] == "bit-exact (portable arithmetic)"
