"""deploy/gpu-check.sh: its stages' records, the summary a person reads (at most 30 lines)
and the JSON a machine reads, and the whole check on this machine."""

import json
import subprocess
import sys
from pathlib import Path

import pytest

from nodes.gpu_check import stages
from nodes.gpu_check.summary import MAX_LINES, lines, report

ROOT = Path(__file__).resolve().parents[2]
JUNIT = """<?xml version="1.0" encoding="utf-8"?><testsuites><testsuite name="pytest">
<testcase classname="tests.test_a" name="test_one" time="0.1"/>
<testcase classname="tests.test_a" name="test_two" time="0.1"><failure message="boom"/></testcase>
<testcase classname="tests.test_b" name="test_three" time="0.0">
<skipped type="pytest.skip" message="Skipped: no `Xvfb` command: install xvfb"/></testcase>
<testcase classname="tests.test_b" name="test_four" time="0.0">
<skipped type="pytest.skip" message="Skipped: no `Xvfb` command: install xvfb"/></testcase>
</testsuite></testsuites>"""


def test_junit_counts_name_failures_and_group_skips(tmp_path):
    (tmp_path / "tests.xml").write_text(JUNIT)
    counts = stages._junit_counts(tmp_path / "tests.xml")
    assert (counts["passed"], counts["failed"], counts["skipped"]) == (1, 1, 2)
    assert counts["failures"] == ["tests.test_a::test_two"]
    assert counts["skip_reasons"] == {"no `Xvfb` command: install xvfb": 2}
    assert stages._junit_counts(tmp_path / "missing.xml")["passed"] == 0


def many_failures() -> list[stages.Stage]:
    return [
        stages.Stage("doctor", stages.PASSED, 4.0, "this node can run cavesim",
                     {"renderers": ["NVIDIA H100"], "versions": ["4.3.0 NVIDIA"]}),
        stages.Stage("tests", stages.FAILED, 300.0, "13 failed", {
            "tier": "full", "parallel": True, "passed": 2000, "failed": 40, "skipped": 13,
            "failures": [f"tests.test_x::test_{n}" for n in range(40)],
            "skip_reasons": {f"reason {n}": 1 for n in range(13)}}),
        stages.Stage("bench", stages.PASSED, 60.0, "", {"gl": {"renderer": "NVIDIA H100"},
            "sizes": [{"particles": 10**k, "gs_tf_frame_ms": 1.0, "compute_frame_ms": 0.5,
                       "compute_speedup": 2.0} for k in range(30)], "skipped": []}),
        stages.Stage("replay", stages.PASSED, 4.0, "2 of 2 logs reproduced", {"logs": [
            {"log": "a.log", "frames": 120, "equal": True, "said": ""}] * 2}),
        stages.Stage("demo", stages.TIMED_OUT, 600.0, "", {"walls": 4, "frames": 900,
            "frames_per_second": None, "barrier_ms": None, "divergences": 0}),
    ]


def test_the_summary_never_passes_30_lines_and_ends_with_the_verdict():
    found = report(many_failures(), "complete")
    shown = lines(found)
    assert len(shown) == MAX_LINES and not found["ok"]
    assert shown[0].startswith("cavesim gpu-check on NVIDIA H100 (4.3.0 NVIDIA), ")
    assert shown[-1] == "verdict: FAIL (tests, demo)"
    assert "... and 35 more (tests.log)" in "\n".join(shown)


def test_an_interrupted_check_says_so_and_keeps_what_finished():
    found = report(many_failures()[:1], "interrupted")
    assert found["ended"] == "interrupted" and not found["ok"]
    assert [s["name"] for s in found["stages"]] == ["doctor"]
    assert lines(found)[-1] == "verdict: FAIL (check interrupted)"


def test_a_stage_past_its_deadline_is_killed_and_recorded(tmp_path):
    code, last = stages.run_child([sys.executable, "-c",
                                   "import time; print('started', flush=True); time.sleep(30)"],
                                  tmp_path / "child.log", deadline=1)
    assert code is None and last == "started"
    assert stages._ended(code, True) == stages.TIMED_OUT


def test_the_shipped_logs_replay_as_a_stage(tmp_path):
    said = []
    stage = stages.replays(tmp_path, said.append)
    assert stage.ended == stages.PASSED and stage.detail == "2 of 2 logs reproduced"
    assert all(log["equal"] and log["frames"] == 120 for log in stage.figures["logs"])
    assert len(said) == 2


@pytest.mark.slow
def test_the_whole_check_runs_here_and_writes_its_json(tmp_path):
    """Quick mode, without the suite (this is the suite): doctor, bench, replays, demo."""
    done = subprocess.run([str(ROOT / "deploy" / "gpu-check.sh"), "--quick", "--tests", "none",
                           "--out", str(tmp_path)], capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    found = json.loads((tmp_path / "gpu-check.json").read_text())
    assert found["ok"] and found["ended"] == "complete"
    assert [s["name"] for s in found["stages"]] == ["doctor", "tests", "bench", "replay", "demo"]
    summary = done.stdout[done.stdout.index("cavesim gpu-check on"):].splitlines()
    assert len(summary) <= MAX_LINES + 1 and summary[-2] == "verdict: PASS"
    assert "llvmpipe" in summary[0] and "Traceback" not in done.stdout + done.stderr


def test_a_second_check_into_the_same_folder_replaces_its_bench_and_demo(tmp_path,
                                                                         monkeypatch):
    """Each stage's command runs in this process with its work left out: the folders the
    first check's bench and demo left are replaced, not refused."""
    from cavesim.tools import bench
    from nodes import cli
    from nodes.commands import run

    def bench_work(scene, sizes, plan, out, console, quick):
        (out / "bench.json").write_text('{"ended": "complete"}')
        return {"ended": "complete"}

    def demo_work(plan, console):
        (plan.out / "report.json").write_text("{}")
        return {"interrupted": False, "final": {}}

    monkeypatch.setattr(bench, "run_bench", bench_work)
    monkeypatch.setattr(run, "run_walls", demo_work)
    monkeypatch.setattr(stages, "run_child",
                        lambda command, log, deadline, on_line=None: (cli.main(command[3:]), ""))
    for _ in range(2):
        assert stages.bench(tmp_path, print, quick=True).ended == stages.PASSED
        assert stages.demo(tmp_path, print, frames=1).ended == stages.PASSED
