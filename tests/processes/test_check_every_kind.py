"""`cavesim check --every-kind`: a fault of every kind in one run of three walls, the
attacks among them, as a user runs it: every fault detected and healed, every wall in
agreement at the end, no traceback anywhere, no process left behind."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
from master_process import running

from nodes.faults import EVERY_KIND_SPACING, KINDS

ROOT = Path(__file__).parents[2]
MINIMAL = ROOT / "config" / "scenes" / "minimal.toml"

pytestmark = pytest.mark.slow


def test_every_kind_at_once_is_detected_healed_and_leaves_nothing_behind(tmp_path):
    session = f"every{os.getpid()}"
    frames = len(KINDS) * EVERY_KIND_SPACING  # the fewest that keep every kind apart
    done = subprocess.run([sys.executable, "-m", "cavesim", "check", "--every-kind",
                           "--frames", str(frames), "--scene", str(MINIMAL), "--out",
                           str(tmp_path), "--session", session],
                          cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    report = json.loads((tmp_path / "check.json").read_text())
    assert sorted(f["kind"] for f in report["faults"]) == sorted(KINDS)
    assert report["all_detected"] and report["all_healed"] and report["all_localised"]
    assert report["final"]["agree"] and report["final"]["all_walls_in"]
    logs = sorted((tmp_path / "logs").glob("*.log"))
    assert len(logs) == 4 and "Traceback" not in done.stderr
    assert [log.name for log in logs if "Traceback" in log.read_text(errors="replace")] == []
    assert sum(report["run"]["rejected_messages"]["nodes"].values()) > 0
    assert running(session) == []
