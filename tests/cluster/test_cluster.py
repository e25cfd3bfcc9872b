"""The lock-step cluster as processes on loopback: faults, soak, replay, shutdown, sessions."""

import json
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from master_process import spawn_master

from cavesim.tools.log_replay import replay
from nodes.check.harness import CheckPlan, run_check
from nodes.cluster_bench.resync import SCENE as RESYNC_SCENE
from nodes.faults import CHECK_MAX_LAG, INFLATION, parse_fault
from nodes.launch.cluster import ClusterPlan, run_cluster
from nodes.launch.launcher import LocalCluster
from nodes.master.budgets import BUDGETS, LAG
from nodes.master.process import MasterConfig

ROOT = Path(__file__).parents[2]
DUST_DEVIL = ROOT / "config" / "scenes" / "dust_devil.toml"
MINIMAL = ROOT / "config" / "scenes" / "minimal.toml"
WALLS = ("front", "left", "right")
SOAK_CAPACITY = 20_000

pytestmark = pytest.mark.slow


# A million particles from the first frame on, living for the whole run: the resync bench's
MILLION = RESYNC_SCENE.format(particles=1_000_000, rate=6e7)


def check(tmp_path, faults, walls=WALLS, frames=150, session="t", scene=DUST_DEVIL, **options):
    """The harness's report; whatever the faults, no process's log holds a traceback."""
    plan = CheckPlan(walls, scene, frames, tuple(map(parse_fault, faults)), tmp_path,
                     session=f"{session}{os.getpid()}", **options)
    report = run_check(plan)
    logs = sorted((tmp_path / "logs").glob("*.log"))
    assert logs and not [log.name for log in logs if "Traceback" in log.read_text(errors="replace")]
    return report


def assert_each_fault_caught(report, faults):
    by_fault = {o["fault"]: o for o in report["faults"]}
    for spec in faults:
        outcome = by_fault[spec]
        assert outcome["detected_frame"] == int(spec.split("@")[1].split(":")[0]), outcome
        if outcome["node"]:
            assert outcome["named"] == [outcome["node"]], outcome
        assert outcome["healed"], outcome
    assert report["final"]["agree"] and report["final"]["all_walls_in"]


def test_state_faults_are_named_by_majority_and_resynced(tmp_path):
    """... and so is a node that reports inflated counters with its state's true checksum
    (an insider): report.json keeps the counters the others agreed on."""
    faults = ["bitflip@20:left", "stale@40:right", "drop@60:front", "seed@1:right",
              "inflate@80:left"]
    report = check(tmp_path, faults)
    assert_each_fault_caught(report, faults)
    assert report["divergences"] == 4  # bitflip, stale, seed, inflate; a drop only stalls
    (inflated,) = [d for d in report["run"]["divergences"] if d["frame"] == 80]
    assert inflated["checksums"]["left"] == inflated["agreed_checksum"]
    assert {name for name, counted in inflated["counters"]["left"].items()
            if counted["values"] != counted["agreed"]} == {"domain_exits", "capacity_drops",
                                                           "ground_deposits"}
    counters = report["run"]["counters"]
    assert counters["capacity_drops"]["total"] < INFLATION
    assert max(counters["ground_deposits"]["largest"].values()) < INFLATION
    assert max(counters["domain_exits"]["total"].values()) < INFLATION


def test_process_faults_are_detected_and_healed(tmp_path):
    faults = ["kill@20:left", "slow@60:right", "rogue@70"]
    report = check(tmp_path, faults, walls=("front", "left", "right", "floor"), frames=200)
    assert_each_fault_caught(report, faults)
    assert report["divergences"] == 0
    assert sum(report["rogue_messages_sent"].values()) == 4
    assert sum(report["run"]["rejected_messages"]["nodes"].values()) >= 4 * 3


def test_a_straggler_is_given_up_within_its_budget_and_one_slow_frame_is_not(tmp_path):
    """A node 2 x --max-lag slow every frame is named at its first, given up at the one past
    the lag budget, and the others' rate is back; a node slow once is named and stays."""
    faults = ["straggler@30:left", "slow@90:right"]
    report = check(tmp_path, faults, frames=120, scene=MINIMAL)
    straggler, slow = report["faults"]
    budget = BUDGETS[LAG].most
    assert (straggler["detected_frame"], straggler["named"]) == (30, ["left"])
    assert straggler["healed"] and straggler["healed_frame"] == 30 + budget + 1, straggler
    detection = straggler["detection"]
    assert [lag["frame"] for lag in detection["lags"]] == list(range(30, 30 + budget + 1))
    rates = detection["frames_per_second"]
    assert rates["while_straggling"] < 1 / CHECK_MAX_LAG < rates["after_given_up"], rates
    assert (slow["detected_frame"], slow["named"], slow["healed"]) == (90, ["right"], True)
    run = report["run"]
    assert [lag["node"] for lag in run["lags"] if lag["frame"] == 90] == ["right"]
    assert [(loss["node"], loss["detected_by"]) for loss in run["losses"]] == [("left", LAG)]
    assert report["final"]["agree"] and run["frames"] == 120


def test_a_wall_given_up_steps_no_queued_frame_and_leaves_at_the_stop(tmp_path):
    """A straggler given up (0.5 s a frame) goes on getting the others' frames faster than
    it steps them: it must skip to the newest and take the STOP, not step every frame queued
    before it until the launcher interrupts it."""
    config = MasterConfig(WALLS, MINIMAL, 60, f"gone{os.getpid()}", max_lag=0.1)
    record = run_cluster(ClusterPlan(config, tmp_path, {"left": (
        "--inject", "straggler@10", "--straggle-delay", "0.5")}))
    assert [(loss.frame, loss.node, loss.detected_by) for loss in record.losses] == [
        (10 + BUDGETS[LAG].most, "left", LAG)]
    assert record.frames == 60 and record.final.agree
    log = (tmp_path / "logs" / "left.log").read_text()
    skipped = [int(ours) for ours in re.findall(r"is ahead of our frame (\d+)", log)]
    assert skipped and 10 + BUDGETS[LAG].most <= skipped[0] < record.frames  # not all stepped
    assert "interrupted" not in log and "Traceback" not in log


def test_attacks_and_a_killed_master_are_refused_and_survived(tmp_path):
    """Forged snapshots and a query flood at a resync, the master killed mid-run and a new
    master taking the nodes over, then the killed run's captured traffic (and an earlier
    run's, a member's and unsent reports) replayed into the new run."""
    faults = ["snapshot-forgery@20:left", "bitflip@30:right", "master-kill@40",
              "replay-attack@70"]
    report = check(tmp_path, faults, frames=100)
    assert_each_fault_caught(report, faults)
    forgery, _, kill, replay = report["faults"]
    assert set(forgery["detection"]["forged_snapshots_served"]) >= {"old-snapshot"}
    assert forgery["detection"]["refused_by_node"] >= 1
    assert report["killed_run"]["frames"] == 39 and kill["detection"]["frames_before"] == 39
    assert kill["detection"]["nodes_that_noticed"] == list(WALLS)
    assert kill["detection"]["nodes_in_the_new_run"] == list(WALLS)
    assert kill["detection"]["killed_run"] != kill["detection"]["new_run"]
    assert report["frames"] == 100 and report["run"]["frames"] == 61
    refused = replay["detection"]["refused_by_master"]
    assert refused.get("wrong-run", 0) >= 1 and refused.get("unsent-frame", 0) >= 1
    assert replay["detection"]["refused_by_nodes"] >= 3 * 3  # earlier run's, member's
    assert report["divergences"] == 2  # the forgery's and the bitflip's, in the killed run
    assert report["run"]["event_totals"]["divergences"] == 0 and report["final"]["agree"]


def test_reports_in_other_walls_names_are_refused_by_their_signer(tmp_path):
    """An insider holding front's key reports a frame in left's and right's names with a
    checksum neither holds: the master takes none, and no wall is judged by them."""
    report = check(tmp_path, ["report-forgery@20"], frames=60, scene=MINIMAL)
    assert_each_fault_caught(report, ["report-forgery@20"])
    (forgery,) = report["faults"]
    assert forgery["detection"]["forged_reports"] == len(WALLS) - 1
    assert forgery["detection"]["refused_by_master_as_wrong_signer"] >= len(WALLS) - 1
    assert report["divergences"] == 0 and report["final"]["agree"]


def test_replayed_queries_are_refused_and_do_not_starve_a_resync(tmp_path):
    """The state and block queries of a node's first resync, captured, are replayed for 3 s
    against its second, with queries of an earlier run: every one is refused, and the
    second resync takes well under a second."""
    report = check(tmp_path, ["query-replay@20:right"], frames=60, scene=MINIMAL)
    (replay,) = report["faults"]
    assert replay["detected_frame"] == 30 and replay["named"] == ["right"] and replay["healed"]
    detection = replay["detection"]
    assert detection["replayed_queries"] > 100 and detection["earlier_run_queries"] == 20
    assert detection["resync_seconds"] < 1.0, detection


def test_replayed_tracking_never_reaches_a_frame(tmp_path):
    report = check(tmp_path, ["tracking-replay@20"], frames=60, scene=MINIMAL)
    assert_each_fault_caught(report, ["tracking-replay@20"])
    (replay,) = report["faults"]
    detection = replay["detection"]
    assert detection["frames_with_the_replayed_pose"] == 0
    assert detection["frames_with_the_fresh_pose"] > 0  # a tracked pose is seen at all
    assert detection["refused_by_master"]["wrong-run"] >= 100


def test_a_walls_key_can_neither_pause_reset_nor_stop_the_run(tmp_path):
    """An insider with a wall's key sends the preview's pause, reset and stop, one a frame:
    the master refuses and counts each before the frame it asks for is made, and the run
    goes to its planned end, never held or started over."""
    report = check(tmp_path, ["control-forgery@20"], frames=30, scene=MINIMAL)
    assert_each_fault_caught(report, ["control-forgery@20"])
    (forgery,) = report["faults"]
    detection = forgery["detection"]
    assert detection["sent"] == [{"frame": 20 + i, "request": request, "refused": True}
                                 for i, request in enumerate(("pause", "reset", "stop"))]
    assert detection["refused_by_master_as_not_an_operator"] == 3
    assert detection["controls_taken"] == [] and report["run"]["user_actions"] == []
    assert report["frames"] == 30 and report["run"]["paused_frames"] == 0
    assert not report["run"]["user_stopped"] and report["divergences"] == 0


def test_counts_forged_with_a_stolen_wall_key_are_named_and_left_out(tmp_path):
    """The forged report reaches the master before the wall's own every time (the harness
    holds the wall until the master has acted on it): the wall is named with the forged
    counts, report.json keeps the agreed ones, and the run goes on."""
    report = check(tmp_path, ["count-forgery@20:left"], frames=60, scene=MINIMAL)
    assert_each_fault_caught(report, ["count-forgery@20:left"])
    (forgery,) = report["faults"]
    detection = forgery["detection"]
    assert detection["resynced_before_its_own_report"] and detection["copied_from"] != "left"
    real = detection["real_counts"]["capacity_drops"]
    assert detection["forged_counts"] == {"capacity_drops": [v + INFLATION for v in real]}
    assert detection["disputed_at_the_frame"]["capacity_drops"]["agreed"] == real
    assert report["run"]["counters"]["capacity_drops"]["total"] < INFLATION
    assert report["rogue_messages_sent"]["forged-count-report"] == 1
    assert report["run"]["frames"] == 60 and report["run"]["losses"] == []


def test_a_second_master_is_refused_and_no_wall_hops(tmp_path):
    report = check(tmp_path, ["second-master@20"], frames=60, scene=MINIMAL)
    assert_each_fault_caught(report, ["second-master@20"])
    (second,) = report["faults"]
    refused = second["detection"]["second_master"]["refused"]
    assert "another master's run" in refused and "refusing to start" in refused
    assert report["run"]["frames"] == 60 and report["divergences"] == 0


def test_a_state_with_the_named_checksum_is_refused_from_another_wall_and_from_the_source(
        tmp_path):
    """Under another wall's key it is refused by its signer; from the resync's source itself
    (its key) by the second wall's digest, each time, and the next holder heals the node."""
    faults = ["snapshot-collision@20:right", "colliding-source@35:left"]
    report = check(tmp_path, faults, frames=60, scene=MINIMAL)
    assert_each_fault_caught(report, faults)
    collision, source = report["faults"]
    for outcome in (collision, source):
        made = outcome["detection"]["collisions"]
        assert made and all(c["colliding_checksum"] == c["named_checksum"] ==
                            c["genuine_checksum"] and len(c["particles_changed"]) == 2
                            for c in made)
    assert collision["detection"]["colliding_snapshots_served"] >= 1
    assert source["detection"]["colliding_snapshots_served"] == 2
    assert source["detection"]["refused_by_node"] >= 2
    tries = [(r["frame"], r["source"], r["confirmer"], r["ok"], r["confirmation"])
             for r in source["detection"]["resyncs"]]
    assert tries == [(k, *try_) for k in (35, 45) for try_ in (
        ("front", "right", False, None), ("right", "front", True, "confirmed by front"))]
    assert report["divergences"] == 3 and report["final"]["agree"]
    log = (tmp_path / "logs" / "left.log").read_text()
    assert "unconfirmed: the particles received are not those right holds" in log


def test_oversized_messages_are_dropped_by_the_transport(tmp_path):
    report = check(tmp_path, ["oversize@20"], frames=60, scene=MINIMAL)
    assert_each_fault_caught(report, ["oversize@20"])
    (oversize,) = report["faults"]
    detection = oversize["detection"]
    assert detection["oversize_sent"] == 50  # 45 messages and 5 queries of 64 MiB
    for wall in WALLS:  # one junk message of 8 MiB reaches each node, none of 64 MiB
        assert detection["after"]["peak_rss_mb"][wall] < detection["before"]["rss_mb"][wall] + 64


def test_a_flood_of_junk_and_queries_is_counted_and_costs_no_memory_and_little_log(tmp_path):
    report = check(tmp_path, ["flood@20"], frames=60, scene=MINIMAL)
    assert_each_fault_caught(report, ["flood@20"])
    (flood,) = report["faults"]
    figures = flood["detection"]
    assert figures["refused_by_nodes"] >= 200_000 * len(WALLS)  # each one counted
    for wall in WALLS:
        before, after = (figures[when] for when in ("before", "after"))
        assert after["rss_mb"][wall] - before["rss_mb"][wall] < 20  # the queues are bounded
        assert after["log_bytes"][wall] - before["log_bytes"][wall] < 20_000  # rate-limited
    assert report["run"]["losses"] == [] and report["final"]["agree"]


def test_two_nodes_name_both_on_a_divergence(tmp_path):
    report = check(tmp_path, ["bitflip@10:left"], walls=("front", "left"), frames=40)
    (divergence,) = report["run"]["divergences"]
    assert divergence["nodes"] == ["front", "left"]
    assert report["final"]["agree"]


def test_a_million_particle_snapshot_streams_in_chunks_and_heals(tmp_path):
    scene = tmp_path / "million.toml"
    scene.write_text(MILLION)
    report = check(tmp_path, ["bitflip@3:left"], walls=("front", "left"), frames=5,
                   session="big", scene=scene, barrier_timeout=20.0, snapshot_chunk=25_000,
                   resync="full")
    (resync,) = report["run"]["resyncs"]
    assert (resync["node"], resync["source"], resync["frame"], resync["ok"]) == \
        ("left", "front", 3, True)
    assert report["final"]["agree"] and report["final"]["all_walls_in"]
    assert report["run"]["live_particles"]["max"] == 1_000_000
    log = (tmp_path / "logs" / "left.log").read_text()
    assert "resynced to frame 3 from front: 1000000 particles in 40 chunks" in log


def test_a_node_killed_near_the_end_rejoins_however_long_its_start_takes(tmp_path):
    """The minimal scene's 40 frames after the kill take well under the second its new
    process needs to start: the harness waits until the new node is up before frame 20."""
    report = check(tmp_path, ["kill@20:left"], frames=60, scene=MINIMAL)
    assert_each_fault_caught(report, ["kill@20:left"])
    assert [j["node"] for j in report["run"]["joins"]] == ["left"]


def test_pause_policy_holds_the_barrier_until_the_lost_node_is_back(tmp_path):
    report = check(tmp_path, ["kill@15:left"], frames=60, on_loss="pause")
    assert_each_fault_caught(report, ["kill@15:left"])
    run = report["run"]
    assert run["joins"] == [], "under pause the node never left the membership"
    assert any(s["frame"] == 15 and "left" in s["nodes"] for s in run["stalls"])
    (resync,) = run["resyncs"]
    assert resync["frame"] == 15 and resync["ok"]


def test_checking_every_k_frames_finds_the_divergence_at_the_next_check(tmp_path):
    report = check(tmp_path, ["bitflip@12:left"], frames=40, check_every=5)
    (divergence,) = report["run"]["divergences"]
    assert divergence["frame"] == 15 and divergence["nodes"] == ["left"]
    assert report["final"]["agree"]
    forensics = json.loads((tmp_path / divergence["forensics"]["file"]).read_text())
    (stream,) = forensics["streams"]
    since = {(r["first_differing_frame"], r["first_differing_frame_exact"])
             for r in stream["records"]}
    assert since == {(12, True)}, forensics  # the history rings tell when it began


def test_a_bitflip_is_localised_to_its_particle_field_and_bit_and_healed_by_delta(tmp_path):
    report = check(tmp_path, ["bitflip@20:left"], frames=25)
    assert_each_fault_caught(report, ["bitflip@20:left"])
    (outcome,) = report["faults"]
    assert outcome["localisation"]["exact"] and report["all_localised"], outcome
    expected = outcome["localisation"]["expected"]
    line = (f"frame 20: left differs from front in particle {expected['record']} "
            f"{expected['field']}: ")
    assert line in (tmp_path / "logs" / "master.log").read_text()
    assert "resynced to frame 20 from front: by delta, " in \
        (tmp_path / "logs" / "left.log").read_text()


def test_healthy_soak_of_1000_frames_has_no_divergence_and_replays(tmp_path, ctx):
    """1000 frames (17 s of the dust devil) on three walls: no divergence, no resync, every
    wall in at the end, and the frame log replays bit for bit. At a capacity of 20,000, not
    the scene's 300,000 (which took over a minute on 2 cores): the cloud is full by frame
    45, its emission overflows it from then on, and the sand that dies (at 3-6 s) is
    replaced by new particles, the same ones on every wall."""
    text = DUST_DEVIL.read_text()
    assert "\ncapacity = 300000\n" in text
    scene = tmp_path / "dust_devil.toml"
    scene.write_text(text.replace("\ncapacity = 300000\n", f"\ncapacity = {SOAK_CAPACITY}\n"))
    report = check(tmp_path, [], frames=1000, session="soak", scene=scene)
    run = report["run"]
    assert run["frames"] == 1000 and run["divergences"] == [] and run["resyncs"] == []
    assert run["live_particles"]["max"] == SOAK_CAPACITY
    assert report["final"]["agree"] and report["final"]["all_walls_in"]
    result = replay(tmp_path / "frames.log", scene, ctx=ctx)
    assert result.frames == 1000 and result.equal, result.mismatches[:3]


def test_ctrl_c_stops_every_process_and_still_writes_the_report(tmp_path):
    command = [sys.executable, "-m", "cavesim", "run", "--walls", "2", "--frames", "100000",
               "--scene", str(MINIMAL), "--out", str(tmp_path), "--session", f"c{os.getpid()}"]
    # SIGINT at its default, as a terminal's Ctrl-C finds it (a test runner started in the
    # background passes SIGINT on ignored, and Python then never raises KeyboardInterrupt)
    run = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                           start_new_session=True,
                           preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    deadline = time.monotonic() + 60
    while not (tmp_path / "frames.log").exists() or (tmp_path / "frames.log").stat().st_size < 2000:
        assert time.monotonic() < deadline and run.poll() is None, run.stdout.read()
        time.sleep(0.1)
    os.kill(run.pid, signal.SIGINT)
    assert run.wait(timeout=60) == 130
    report = json.loads((tmp_path / "report.json").read_text())
    assert report["interrupted"] and 0 < report["frames"] < 100000
    assert report["divergences"] == []
    leftovers = subprocess.run(["pgrep", "-f", f"--session c{os.getpid()}"],
                               capture_output=True, text=True).stdout
    assert leftovers == ""


def test_sessions_with_different_prefixes_never_interfere(tmp_path):
    """Two clusters on one zenoh mesh: each runs clean, neither sees the other's messages."""
    first = LocalCluster(MINIMAL, tmp_path / "a", f"a{os.getpid()}")
    second = LocalCluster(MINIMAL, tmp_path / "b", f"b{os.getpid()}")
    with first, second:
        for cluster in (first, second):
            for wall in ("front", "left"):
                cluster.start_node(wall)
        masters = [spawn_master(first, ("front", "left"), 300),
                   spawn_master(second, ("front", "left"), 300,
                                       ("--connect", first.master_endpoint))]
        for master in masters:
            master.stdout.read()
            assert master.wait(timeout=120) == 0
    for out in (tmp_path / "a", tmp_path / "b"):
        report = json.loads((out / "report.json").read_text())
        assert report["frames"] == 300 and report["divergences"] == []
        assert not report["rejected_messages"]["master"]
        assert not any(report["rejected_messages"]["nodes"].values())


@pytest.mark.parametrize(("cores", "nodes", "threads"), [(2, 4, "0"), (2, 2, "0"), (16, 4, "4"),
                                                         (16, 8, "2"), (16, 9, "0")])
def test_a_node_that_never_draws_gets_its_share_of_llvmpipes_threads(monkeypatch, tmp_path,
                                                                   cores, nodes, threads):
    monkeypatch.setattr(os, "cpu_count", lambda: cores)
    monkeypatch.delenv("LP_NUM_THREADS", raising=False)
    cluster = LocalCluster(MINIMAL, tmp_path, "t", expected_nodes=nodes,
                           drawing=frozenset({"front"}))
    assert cluster.node_environment("left")["LP_NUM_THREADS"] == threads
    assert "LP_NUM_THREADS" not in cluster.node_environment("front")  # it draws: Mesa's own
    monkeypatch.setenv("LP_NUM_THREADS", "3")  # the user's setting wins
    assert cluster.node_environment("left")["LP_NUM_THREADS"] == "3"
