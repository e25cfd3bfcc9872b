"""The stages of a GPU node's check, each a `cavesim` or pytest child process with a
deadline, each ending in a `Stage` record that says how it ended and what it measured."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import threading
import time
import xml.etree.ElementTree as ElementTree
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from nodes.arguments import REPO_ROOT

LOGS = REPO_ROOT / "tests" / "data" / "logs"  # recorded on llvmpipe, portable arithmetic
DEMO_FRAMES = 900  # the brownout demo's whole timeline
QUICK_DEMO_FRAMES = 120  # --quick: its first 2 s
DEMO_RENDER_EVERY = 100  # a few pictures per wall: the renderer runs too
TEST_TIERS = ("full", "fast", "none")
DEADLINES = {"doctor": 180, "tests": 1800, "bench": 300, "replay": 300, "demo": 600}  # s
PASSED, FAILED, TIMED_OUT, NOT_RUN = "passed", "failed", "timed out", "not run"

Say = Callable[[str], None]  # prints one progress line


@dataclass
class Stage:
    """One stage's record: how it ended, in how long, and its figures."""

    name: str
    ended: str = NOT_RUN  # PASSED, FAILED, TIMED_OUT, NOT_RUN, or "error: ..."
    seconds: float = 0.0
    detail: str = ""  # one line: why it failed, or what it found
    figures: dict = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        return self.ended in (PASSED, NOT_RUN)


def run_child(command: list[str], log: Path, deadline: float,
              on_line: Callable[[str], None] = lambda line: None) -> tuple[int | None, str]:
    """Run `command` from the repository root, its output into `log` (and each line to
    `on_line`); (exit code, or None when it was killed at `deadline` s, its last line)."""
    last, killed = "", threading.Event()
    with log.open("w") as out, subprocess.Popen(
            command, cwd=REPO_ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
            text=True, env={**os.environ, "PYTHONUNBUFFERED": "1"}) as child:
        watchdog = threading.Timer(deadline, lambda: (killed.set(), child.kill()))
        watchdog.start()
        try:
            for line in child.stdout:
                out.write(line)
                out.flush()  # the log is followed while the stage runs
                last = line.strip() or last
                on_line(line)
            code = child.wait()
        except BaseException:  # interrupted: the child goes with us
            child.kill()
            raise
        finally:
            watchdog.cancel()
    return (None if killed.is_set() else code), last


def cavesim(*args: str) -> list[str]:
    return [sys.executable, "-m", "cavesim", *args]


def timed(stage: Stage, body: Callable[[], None]) -> Stage:
    started = time.monotonic()
    try:
        body()
    finally:
        stage.seconds = round(time.monotonic() - started, 1)
    return stage


def doctor(out: Path, say: Say) -> Stage:
    stage = Stage("doctor")

    def body() -> None:
        code, last = run_child(cavesim("doctor", "--out", str(out / "doctor.json")),
                               out / "doctor.log", DEADLINES["doctor"])
        found = _json(out / "doctor.json")
        verdict = found.get("verdict", {})
        devices = [d for d in found.get("devices", []) if d.get("opened")]
        stage.figures = {"verdict": verdict, "renderers": [d["renderer"] for d in devices],
                         "versions": [d["version"] for d in devices],
                         "kinds": [d["kind"] for d in devices]}
        stage.ended = _ended(code, verdict.get("ok"))
        stage.detail = verdict.get("reason") or last

    return timed(stage, body)


def tests(out: Path, tier: str, say: Say) -> Stage:
    """The suite (`full`) or its fast tier (`fast`: without the tests marked slow), on
    every core where pytest-xdist is installed (handed out as deploy/test.sh does)."""
    stage = Stage("tests")
    if tier == "none":
        stage.detail = "not run (--tests none)"
        return stage
    command = [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider",
               "--junitxml", str(out / "tests.xml"), "tests"]
    if tier == "fast":
        command[3:3] = ["-m", "not slow"]
    if _has_xdist():
        command[3:3] = ["-n", "auto", "--dist", "loadgroup"]

    def progress(line: str) -> None:
        if line.rstrip().endswith("%]"):
            say(f"tests: {line.rstrip()[-5:-1].strip()} done after "
                f"{time.monotonic() - started:.0f} s")

    def body() -> None:
        code, last = run_child(command, out / "tests.log", DEADLINES["tests"], progress)
        counts = _junit_counts(out / "tests.xml")
        stage.figures = {"tier": tier, "parallel": _has_xdist(), **counts}
        stage.ended = _ended(code, code == 0)
        stage.detail = last

    started = time.monotonic()
    return timed(stage, body)


def bench(out: Path, say: Say, quick: bool = False) -> Stage:
    """The default bench (1M, 10M and the largest capacity, both engine paths), or with
    `quick` the bench's one-minute answer."""
    stage = Stage("bench")
    # --force here and in the demo: a check run again into its --out replaces the last one's
    command = cavesim("bench", "--out", str(out / "bench"), "--force",
                      *(["--quick"] if quick else []))

    def body() -> None:
        code, last = run_child(command, out / "bench.log",
                               DEADLINES["bench"], lambda line: say(f"bench: {line.strip()}")
                               if line.strip().startswith(tuple("0123456789")) else None)
        report = _json(out / "bench" / "bench.json")
        stage.figures = {"gl": report.get("gl", {}), "sizes": [
            {"particles": s["particles"], "gs_tf_frame_ms": _ms(s, "gs_tf_frame"),
             "compute_frame_ms": _ms(s, "compute_frame"),
             "compute_speedup": s.get("ratios", {}).get("compute_speedup")}
            for s in report.get("sizes", [])], "skipped": report.get("skipped_sizes", [])}
        stage.ended = _ended(code, code == 0)
        stage.detail = last

    return timed(stage, body)


def replays(out: Path, say: Say) -> Stage:
    """Every shipped frame log, replayed: each checksum must come back bit for bit."""
    stage = Stage("replay")

    def body() -> None:
        results = []
        for log in sorted(LOGS.glob("*.log")):
            folder = out / "replay" / log.stem
            code, last = run_child(cavesim("replay", str(log), "--out", str(folder)),
                                   out / f"replay-{log.stem}.log", DEADLINES["replay"])
            found = _json(folder / "replay.json")
            results.append({"log": log.name, "frames": found.get("frames", 0),
                            "equal": bool(found.get("equal")) and code == 0,
                            "mismatches": found.get("mismatch_count"), "said": last})
            say(f"replay: {log.name}: {last}")
        stage.figures = {"logs": results}
        stage.ended = PASSED if results and all(r["equal"] for r in results) else FAILED
        stage.detail = f"{sum(r['equal'] for r in results)} of {len(results)} logs reproduced"

    return timed(stage, body)


def demo(out: Path, say: Say, frames: int = DEMO_FRAMES) -> Stage:
    """The brownout demo on the default 4-wall CAVE, one node process per wall."""
    stage = Stage("demo")

    def body() -> None:
        code, last = run_child(cavesim("run", "--frames", str(frames), "--render-every",
                                       str(DEMO_RENDER_EVERY), "--out", str(out / "demo"),
                                       "--force"),
                               out / "demo.log", DEADLINES["demo"])
        report = _json(out / "demo" / "report.json")
        stage.figures = {key: report.get(key) for key in
                         ("ended", "frames", "frames_per_second", "barrier_ms")}
        stage.figures["walls"] = len(report.get("gpus", {}))
        stage.figures["divergences"] = len(report.get("divergences", []))
        stage.ended = _ended(code, code == 0 and not stage.figures["divergences"])
        stage.detail = last

    return timed(stage, body)


def _ended(code: int | None, ok: bool | None) -> str:
    if code is None:
        return TIMED_OUT
    return PASSED if ok else FAILED


def _json(path: Path) -> dict:
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError):
        return {}


def _ms(size: dict, path: str) -> float | None:
    seconds = size.get("seconds", {}).get(path)
    return None if seconds is None else round(seconds * 1e3, 3)


def _has_xdist() -> bool:
    try:
        import xdist  # noqa: F401
    except ImportError:
        return False
    return True


def _junit_counts(path: Path) -> dict:
    """Passed, failed, skipped (with their reasons) and the failed tests' names."""
    try:
        root = ElementTree.parse(path).getroot()
    except (OSError, ElementTree.ParseError):
        return {"passed": 0, "failed": 0, "skipped": 0, "failures": [], "skip_reasons": {}}
    cases = list(root.iter("testcase"))
    failures = [f"{c.get('classname')}::{c.get('name')}" for c in cases
                if c.find("failure") is not None or c.find("error") is not None]
    skipped = [c.find("skipped") for c in cases if c.find("skipped") is not None]
    reasons: dict[str, int] = {}
    for skip in skipped:
        reason = (skip.get("message") or "").split(":", 1)[-1].strip()[:80]
        reasons[reason] = reasons.get(reason, 0) + 1
    return {"passed": len(cases) - len(failures) - len(skipped), "failed": len(failures),
            "skipped": len(skipped), "failures": failures, "skip_reasons": reasons}
