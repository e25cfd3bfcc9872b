"""The mixed-hardware tolerance mode as processes on loopback: a node made to drift by a
ULP (as another GPU's rounding would) is tolerated and its drift reported, resynced from
the authority at the next period; a node shoved far beyond the tolerance is named and
resynced at once; the frame log holds the authority's checksums, which a replay on its kind
of GPU reproduces. The bit-exact mode names the same ULP at once."""

import os
from pathlib import Path

import pytest

from cavesim.core.wire.credentials import generate
from cavesim.tools.log_replay import replay
from nodes.launch.cluster import ClusterPlan, run_cluster
from nodes.master.process import MasterConfig
from nodes.master.tolerance import Tolerance
from nodes.mixed_hardware import node_arguments

ROOT = Path(__file__).parents[2]
DUST_DEVIL = ROOT / "config" / "scenes" / "dust_devil.toml"  # particles from frame 1 on
WALLS = ("front", "left")
JITTER, SHOVE, PERIOD, FRAMES = 5, 30, 20, 36

pytestmark = pytest.mark.slow


def run(out: Path, frames: int, tolerance: Tolerance | None, faults: tuple[str, ...]):
    out.mkdir()
    master = MasterConfig(WALLS, DUST_DEVIL, frames, f"mixed{os.getpid()}",
                          credentials=generate(), barrier_timeout=1.0, tolerance=tolerance,
                          frame_log=out / "frames.log")
    node_args = {wall: node_arguments(tolerance) for wall in WALLS}
    node_args["left"] += tuple(arg for fault in faults for arg in ("--inject", fault))
    return run_cluster(ClusterPlan(master, out, node_args))


def test_a_ulp_is_tolerated_and_reported_a_shove_is_resynced_and_bit_exact_names_the_ulp(
        tmp_path, ctx):
    tolerance = Tolerance("front", resync_every=PERIOD, sample=64)
    record = run(tmp_path / "mixed", FRAMES, tolerance, (f"jitter@{JITTER}", f"shove@{SHOVE}"))
    summary = record.summary()
    assert summary["mode"] == "mixed-hardware tolerance"
    drift = summary["tolerance"]["drift"]["left"]
    by_frame = dict(zip(drift["frames"], drift["position_max_m"], strict=True))
    assert drift["comparisons"] == FRAMES and by_frame[JITTER - 1] == 0.0
    ulp = [by_frame[k] for k in range(JITTER, PERIOD)]
    assert all(0 < d < tolerance.position for d in ulp), ulp
    assert all(by_frame[k] == 0.0 for k in (*range(PERIOD + 1, SHOVE), *range(SHOVE + 1,
                                                                             FRAMES + 1)))
    assert by_frame[SHOVE] > tolerance.position
    (divergence,) = record.divergences  # the shove: the ULP was not one
    assert (divergence.frame, divergence.nodes) == (SHOVE, ("left",))
    resyncs = [(r.frame, r.node, r.source, r.ok) for r in record.resyncs]
    assert resyncs == [(PERIOD, "left", "front", True), (SHOVE, "left", "front", True)]
    assert summary["tolerance"]["periodic_resyncs"] == 1
    assert record.final.agree and record.final.all_walls_in
    replayed = replay(tmp_path / "mixed" / "frames.log", DUST_DEVIL, ctx=ctx)
    assert replayed.frames == FRAMES and replayed.equal, replayed.mismatches[:3]

    bit_exact = run(tmp_path / "bit-exact", JITTER + 2, None, (f"jitter@{JITTER}",))
    assert bit_exact.summary()["mode"] == "bit-exact"
    (divergence,) = bit_exact.divergences
    assert divergence.frame == JITTER and "left" in divergence.nodes
    assert bit_exact.final.agree
