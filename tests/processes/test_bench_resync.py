"""`cavesim bench --resync` on a small state: both ways heal the bitflip (the full snapshot,
the delta), confirmed by the third wall, the bitflip is localised, resync.json says what
moved and what the confirmation costs; and its flags."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from nodes.cli import main

ROOT = Path(__file__).parents[2]
RUN_MAIN = "import sys; from nodes.cli import main; sys.exit(main(sys.argv[1:]))"


@pytest.mark.slow
def test_a_small_resync_bench_heals_both_ways_and_writes_its_figures(tmp_path):
    out = tmp_path / "bench"
    path = os.pathsep.join(filter(None, (str(ROOT), os.environ.get("PYTHONPATH"))))
    done = subprocess.run([sys.executable, "-c", RUN_MAIN, "bench", "--resync", "--sizes",
                           "20000", "--out", str(out)], cwd=tmp_path,
                          env={**os.environ, "PYTHONPATH": path}, capture_output=True,
                          text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    report = json.loads((out / "resync.json").read_text())
    full, delta = report["ways"]
    assert (full["mode"], delta["mode"]) == ("full", "delta")
    assert full["how"] == "20000 particles in 1 chunks" and delta["how"].startswith("by delta")
    assert full["bytes"] > 20000 * 40 > 50 * delta["bytes"]  # 800 KB against 13 KB
    assert full["localised"] and delta["localised"]
    assert full["confirmer"] == delta["confirmer"] == "left"  # the second healthy wall
    assert (full["confirm_digests"], delta["confirm_digests"]) == (2, 2)
    confirmation = report["confirmation"]
    assert confirmation["particles"] == 20000 and confirmation["bytes"] == 800_000
    assert confirmation["sha256_ms"] > 0 and confirmation["confirmer_answer_ms"] > 0
    ring = report["history_ring"]
    blocks = 13 + 1  # 200,000 words of particles in blocks of 16,384, one of emitters
    assert ring["bytes_per_frame"] == blocks * 16 and ring["ring_bytes"] == 64 * blocks * 16
    assert "delta:" in done.stdout and "history ring:" in done.stdout
    assert "confirmation at 20,000 particles: sha256" in done.stdout


@pytest.mark.parametrize(("flags", "message"), [
    (["--cluster"], "--cluster: not with --resync"),
    (["--frames", "5"], "--frames: not with --resync"),
    (["--sizes", "1000,2000"], "one particle count"),
    (["--soak"], "--resync: not with --soak"),
])
def test_resync_bench_flags_that_do_not_fit_are_refused(tmp_path, capsys, flags, message):
    assert main(["bench", "--resync", *flags, "--out", str(tmp_path / "o")]) == 2
    assert message in capsys.readouterr().err
