"""`cavesim bench --cluster`: the reports it writes, the figures in them, and bad flags.

Benchmark figures, not timed tests: the run checks that the figures exist, are positive and
finite and are judged against the targets, never how large they are. The benchmark runs in a
child process (it opens a GL context of its own and starts cluster processes).
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys

import pytest

from cavesim.core.frame_cost import FRAME_PHASES, PHASES
from nodes.cli import main
from nodes.cluster_bench.barrier import TARGETS, build_report
from nodes.cluster_bench.tables import target_line

RUN_MAIN = "import sys; from nodes.cli import main; sys.exit(main(sys.argv[1:]))"
pytestmark = pytest.mark.xdist_group("bench_cluster")  # one cluster bench, on one worker


@pytest.fixture(scope="module")
def cluster_bench(tmp_path_factory):
    """One short run: barrier with 2 nodes, the swap barrier with 2 and 4 windows (on an
    Xvfb of its own), the 4-wall lock-step run, 30 frames each."""
    work = tmp_path_factory.mktemp("bench_cluster")
    out = work / "reports"
    argv = ["bench", "--cluster", "--nodes", "2", "--frames", "30", "--out", str(out)]
    environment = {name: value for name, value in os.environ.items() if name != "DISPLAY"}
    done = subprocess.run([sys.executable, "-c", RUN_MAIN, *argv], cwd=work, env=environment,
                          capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    return done, out, json.loads((out / "cluster.json").read_text())


def positive(*values) -> bool:
    return all(isinstance(x, int | float) and math.isfinite(x) and x > 0 for x in values)


@pytest.mark.slow
def test_barrier_figures_per_node_count(cluster_bench):
    _, out, report = cluster_bench
    assert report["command"] == "bench --cluster" and report["frames"] == 30
    barrier = report["barrier"]
    assert barrier["scene"].endswith("minimal.toml")
    (run,) = barrier["runs"]
    assert run["nodes"] == 2 and run["frames"] == 30 and run["divergences"] == 0
    assert positive(*run["barrier_ms"].values(), run["frames_per_second"])
    assert run["barrier_ms"]["p50"] <= run["barrier_ms"]["p99"] <= run["barrier_ms"]["max"]
    cpu = run["cpu_ms_per_frame"]  # the master and both nodes, per frame
    assert set(cpu["nodes"]) == {"front", "left"} and positive(cpu["total"])
    assert cpu["total"] == pytest.approx(cpu["master"] + sum(cpu["nodes"].values()), abs=2e-3)
    assert run["cpu_floor_ms"] == pytest.approx(cpu["total"] / report["cpu_count"], abs=1e-3)
    assert (out / "cluster" / "barrier-2" / "report.json").exists()
    one_node = barrier["one_node"]
    assert one_node["systems"] == 1 and positive(*one_node["frame_ms"].values())
    assert one_node["final_checksum"] == run["final_checksum"]  # the same frames


@pytest.mark.slow
def test_where_each_nodes_frame_goes_is_measured_and_shown(cluster_bench):
    done, out, report = cluster_bench
    (run,) = report["barrier"]["runs"]
    cost = run["frame_cost_ms"]
    assert set(cost) == {"front", "left"} and all(list(cost[w]) == list(PHASES) for w in cost)
    for wall in cost:
        assert positive(cost[wall]["step"]["p50"], cost[wall]["checksum"]["p50"],
                        cost[wall]["input_wait"]["p99"], cost[wall]["gpu_sync"]["max"],
                        cost[wall]["particle_pass"]["p50"], cost[wall]["checksum_pass"]["p50"])
        assert cost[wall]["render"]["max"] == 0  # the barrier's nodes draw nothing
    assert "where a node's frame goes" in done.stdout
    markdown = (out / "cluster.md").read_text()
    assert "## Where a node's frame goes" in markdown
    assert all(f"- {phase} ({clock}): " in markdown
               for phase, (clock, _) in FRAME_PHASES.items())
    assert "| barrier (master) | CPU |" in markdown


@pytest.mark.slow
@pytest.mark.requires("xvfb")
def test_swap_skew_of_two_and_four_windows(cluster_bench):
    _, out, report = cluster_bench
    swap = report["swap"]
    assert swap["x_server"].startswith("Xvfb :") and swap["window_px"] == 64
    assert [run["nodes"] for run in swap["runs"]] == [2, 4]
    for run in swap["runs"]:
        book = run["swap"]
        assert book["frames"] >= 29 and book["order_violations"] == 0 and book["stalls"] == []
        assert book["incomplete"] == 0 and run["divergences"] == 0
        assert 0 <= book["skew_ms"]["p50"] <= book["skew_ms"]["p99"] <= book["skew_ms"]["max"]
        walls = run["nodes"]
        assert (out / "cluster" / f"swap-{walls}" / "desktop.toml").exists()


@pytest.mark.slow
def test_lockstep_against_back_to_back(cluster_bench):
    _, _, report = cluster_bench
    step = report["lockstep"]
    assert step["walls"] == 4 and step["cluster"]["divergences"] == 0
    assert positive(step["cluster_fps"], step["back_to_back_fps"])
    assert step["lockstep_cost"] == pytest.approx(
        1 - step["cluster_fps"] / step["back_to_back_fps"])
    assert step["back_to_back"]["frames_with_unequal_systems"] == 0
    # the same frames (the master's clock) stepped in one process end on the same state
    assert step["same_final_checksum"]


@pytest.mark.slow
@pytest.mark.requires("xvfb")
def test_targets_are_judged_and_printed(cluster_bench):
    done, out, report = cluster_bench
    assert [(t["name"], t["nodes"]) for t in report["targets"]] == [
        ("barrier_p99_ms", 2), ("node_cpu_ms", 2), ("swap_skew_p99_ms", 2),
        ("swap_skew_p99_ms", 4), ("lockstep_cost", 4)]
    for target in report["targets"]:
        assert math.isfinite(target["measured"])
        assert isinstance(target["met"], bool) or "cores <" in target["why"]
        assert target_line(target) in done.stdout
        assert f"- {target_line(target)}" in (out / "cluster.md").read_text()
    assert f"wrote {out / 'cluster.json'}" in done.stdout


def bench_report(cores, monkeypatch):
    """build_report's verdicts on made-up runs, as on a machine of `cores` cores."""
    def run(nodes, p99, skew=None, node_cpu=(0.25, 0.35)):
        return {"nodes": nodes, "barrier_ms": {"p50": 1.0, "p99": p99, "max": 9.0},
                "cpu_ms_per_frame": {"master": 0.5, "total": 2.0,
                                     "nodes": dict(zip(("front", "left"), node_cpu, strict=True))},
                "swap": {"skew_ms": {"p50": 0.1, "p99": skew, "max": 5.0}}}
    monkeypatch.setattr(os, "cpu_count", lambda: cores)
    cluster = {"nodes": 4, "frames_per_second": 86.0, "final_checksum": "ab"}
    back_to_back = {"frames_per_second": 100.0, "final_checksum": "ab"}
    barrier = {"scene": "tiny.toml", "runs": [run(2, 1.0), run(4, 2.5), run(8, 2.0)],
               "one_node": {}}
    swap = {"runs": [run(2, 3.0, skew=0.5), run(4, 3.0, skew=1.0)]}
    return build_report(barrier, swap, cluster, back_to_back, {}, 300)


def test_targets_follow_the_bounds(monkeypatch):
    report = bench_report(16, monkeypatch)
    judged = [(t["name"], t["nodes"], t["met"]) for t in report["targets"]]
    assert judged == [("barrier_p99_ms", 2, True),  # 1.0 ms <= 1
                      ("barrier_p99_ms", 4, False),  # 2.5 ms > 2
                      ("barrier_p99_ms", 8, True),  # 2.0 ms <= 2
                      ("node_cpu_ms", 2, False),  # the busier node's 0.35 ms > 0.3
                      ("swap_skew_p99_ms", 2, True), ("swap_skew_p99_ms", 4, False),  # not < 1
                      ("lockstep_cost", 4, False)]  # 14% > 10%
    assert report["lockstep"]["lockstep_cost"] == pytest.approx(0.14)
    assert report["lockstep"]["same_final_checksum"]
    assert {t["name"] for t in report["targets"]} == {t.name for t in TARGETS}
    assert report["barrier"]["runs"][0]["cpu_floor_ms"] == pytest.approx(2.0 / 16, abs=1e-3)


def test_on_too_few_cores_the_barrier_is_not_judged_and_the_cpu_floor_is_named(monkeypatch):
    report = bench_report(4, monkeypatch)
    barrier = [t for t in report["targets"] if t["name"] == "barrier_p99_ms"]
    assert [t["met"] for t in barrier] == [True, None, None]  # 4 cores: 2 nodes + 2 only
    assert barrier[1]["why"] == "4 cores < 4 nodes + 2: the CPU floor is 0.5 ms"
    assert target_line(barrier[1]).endswith(
        "measured 2.500 ms - not judged (4 cores < 4 nodes + 2: the CPU floor is 0.5 ms)")


def test_without_an_x_display_the_swap_targets_are_left_out():
    cluster = {"nodes": 4, "frames_per_second": 86.0, "final_checksum": "ab"}
    back_to_back = {"frames_per_second": 100.0, "final_checksum": "ab"}
    barrier = {"scene": "tiny.toml", "runs": [], "one_node": {}}
    report = build_report(barrier, {"skipped": "no X display"}, cluster, back_to_back, {}, 300)
    assert [t["name"] for t in report["targets"]] == ["lockstep_cost"]
    assert report["swap"] == {"skipped": "no X display"}


@pytest.mark.parametrize("argv, flag", [
    (["--cluster", "--nodes", "0"], "--nodes"),
    (["--cluster", "--nodes", "2,x"], "--nodes"),
    (["--cluster", "--nodes", "65"], "--nodes"),
    (["--nodes", "2"], "--nodes"),
    (["--cluster", "--sizes", "1000"], "--sizes"),
    (["--cluster", "--scene", "/nonexistent.toml"], "--scene"),
])
def test_bad_flags_exit_2_with_one_line_naming_the_flag(capsys, tmp_path, argv, flag):
    assert main(["bench", *argv, "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and flag in err
    assert not any(tmp_path.iterdir())
