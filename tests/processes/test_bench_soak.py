"""`cavesim bench --soak`: a tiny soak's soak.json and table, the memory sampler, bad flags.

Memory figures, not limits: the run checks that every process was sampled when asked and
the growth adds up, never how large the figures are. The soak runs in a child process,
whose nodes import this checkout's cavesim (PYTHONPATH), not an installed one.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import pytest

from nodes.cli import main
from nodes.cluster_bench.soak import MASTER, MemorySampler, growth_mb
from nodes.launch.launcher import resident_mb

ROOT = Path(__file__).parents[2]
RUN_MAIN = "import sys; from nodes.cli import main; sys.exit(main(sys.argv[1:]))"
pytestmark = pytest.mark.xdist_group("bench_soak")  # one tiny soak, on one worker


@pytest.fixture(scope="module")
def tiny_soak(tmp_path_factory):
    """2 walls of the minimal scene, 300 frames, memory every 100 frames."""
    work = tmp_path_factory.mktemp("soak")
    out = work / "reports"
    argv = ["bench", "--soak", "--walls", "2", "--frames", "300", "--sample-every", "100",
            "--out", str(out)]
    path = os.pathsep.join(filter(None, (str(ROOT), os.environ.get("PYTHONPATH"))))
    done = subprocess.run([sys.executable, "-c", RUN_MAIN, *argv], cwd=work,
                          env={**os.environ, "PYTHONPATH": path}, capture_output=True,
                          text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    return done, out, json.loads((out / "soak.json").read_text())


def test_tiny_soak_samples_every_process(tiny_soak):
    _, out, report = tiny_soak
    assert report["command"] == "bench --soak" and report["scene"].endswith("minimal.toml")
    assert report["walls"] == 2 and report["frames"] == 300 and report["sample_every"] == 100
    assert report["divergences"] == 0 and report["seconds"] > 0
    assert [sample["frame"] for sample in report["samples"]] == [0, 100, 200, 300]
    for sample in report["samples"]:
        assert list(sample["rss_mb"]) == [MASTER, "front", "left"]
        assert all(mb > 0 for mb in sample["rss_mb"].values())
    first, second, last = (report["samples"][i]["rss_mb"] for i in (0, 1, -1))
    for name in (MASTER, "front", "left"):
        assert report["growth_mb"][name] == pytest.approx(last[name] - first[name], abs=2e-3)
        assert report["steady_growth_mb"][name] == pytest.approx(last[name] - second[name],
                                                                 abs=2e-3)
    assert report["renderer"] and set(report["gpus"]) == {"front", "left"}
    assert (out / "soak" / "report.json").exists() and (out / "soak" / "frames.log").exists()


def test_tiny_soak_prints_each_sample_and_the_table(tiny_soak):
    done, out, _ = tiny_soak
    assert "frame 100 (" in done.stdout and "master MB" in done.stdout
    assert "growth" in done.stdout and f"wrote {out / 'soak.json'}" in done.stdout


def test_the_sampler_reads_each_process_at_frame_0_every_nth_and_the_last():
    me = os.getpid()
    cluster = SimpleNamespace(nodes={"front": SimpleNamespace(pid=me)})
    seen = []
    sampler = MemorySampler(frames=25, every=10, on_sample=seen.append)
    for k in range(1, 26):
        sampler.before_frame(cluster, k)
        sampler.after_frame(k)
    assert [s["frame"] for s in sampler.samples] == [0, 10, 20, 25] and seen == sampler.samples
    assert all(set(s["rss_mb"]) == {MASTER, "front"} for s in sampler.samples)
    assert sampler.samples[0]["rss_mb"]["front"] == pytest.approx(resident_mb(me), rel=0.5)


def test_a_process_gone_reads_as_none_and_has_no_growth():
    assert resident_mb(2**22 + 1) is None  # above the kernel's largest pid
    first = {"frame": 0, "rss_mb": {MASTER: 50.0, "front": 100.0}}
    last = {"frame": 10, "rss_mb": {MASTER: 52.5, "front": None}}
    assert growth_mb(first, last) == {MASTER: 2.5, "front": None}


@pytest.mark.parametrize("argv, flag", [
    (["--soak", "--walls", "0"], "--walls"),
    (["--soak", "--walls", "x"], "--walls"),
    (["--soak", "--sample-every", "0"], "--sample-every"),
    (["--soak", "--frames", "100", "--sample-every", "200"], "--sample-every"),
    (["--soak", "--frames", "-5"], "--frames"),
    (["--soak", "--cluster"], "--cluster"),
    (["--soak", "--nodes", "2"], "--nodes"),
    (["--soak", "--sizes", "1000"], "--sizes"),
    (["--soak", "--scene", "/nonexistent.toml"], "--scene"),
    (["--walls", "2"], "--walls"),
    (["--cluster", "--sample-every", "10"], "--sample-every"),
])
def test_bad_soak_flags_exit_2_with_one_line_naming_the_flag(capsys, tmp_path, argv, flag):
    assert main(["bench", *argv, "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and flag in err
    assert not any(tmp_path.iterdir())
