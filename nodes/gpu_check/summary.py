"""The check's verdict for a person (at most 30 lines) and for a machine (gpu-check.json)."""

from __future__ import annotations

import json
import os
import platform
from datetime import UTC, datetime
from pathlib import Path

from cavesim.core.output import writing
from nodes.gpu_check.stages import Stage

MAX_LINES = 30
MAX_FAILURES_SHOWN = 5


def report(stages: list[Stage], ended: str) -> dict:
    """gpu-check.json: every stage as it ended, and how the whole check ended."""
    return {"command": "gpu-check", "ended": ended,
            "ok": ended == "complete" and all(stage.ok for stage in stages),
            "host": platform.node(), "cpu_count": os.cpu_count(),
            "created": datetime.now(UTC).isoformat(timespec="seconds"),
            "stages": [{"name": s.name, "ended": s.ended, "ok": s.ok, "seconds": s.seconds,
                        "detail": s.detail, "figures": s.figures} for s in stages]}


def write(found: dict, path: Path) -> None:
    with writing(path):
        path.write_text(json.dumps(found, indent=2) + "\n")


def lines(found: dict) -> list[str]:
    """The summary: the GPU, one block per stage, the verdict; never more than MAX_LINES."""
    stages = {stage["name"]: stage for stage in found["stages"]}
    shown = [_headline(stages.get("doctor"), found["cpu_count"])]
    for name in ("doctor", "tests", "bench", "replay", "demo"):
        if name in stages:
            shown += _stage_lines(stages[name])
    failed = [s["name"] for s in found["stages"] if not s["ok"]]
    verdict = "PASS" if found["ok"] else \
        f"FAIL ({', '.join(failed) or 'check ' + found['ended']})"
    shown.append(f"verdict: {verdict}")
    return shown[:MAX_LINES - 1] + shown[-1:] if len(shown) > MAX_LINES else shown


def _headline(doctor: dict | None, cpus: int) -> str:
    figures = (doctor or {}).get("figures", {})
    renderers = ", ".join(f"{r} ({v})" for r, v in zip(figures.get("renderers", []),
                                                       figures.get("versions", []),
                                                       strict=False))
    return f"cavesim gpu-check on {renderers or 'no GL device'}, {cpus} CPUs"


def _stage_lines(stage: dict) -> list[str]:
    head = f"{stage['name']:<7} {stage['ended']:<9} {stage['seconds']:>6.1f} s"
    f = stage["figures"]
    if stage["name"] == "doctor":
        return [f"{head}  {stage['detail']}"]
    if stage["name"] == "tests":
        if stage["ended"] == "not run":
            return [f"{head}  {stage['detail']}"]
        parallel = ", in parallel" if f.get("parallel") else ""
        skips = "; ".join(f"{n} {reason}" for reason, n in f.get("skip_reasons", {}).items())
        out = [f"{head}  {f.get('tier')} tier{parallel}: {f.get('passed', 0)} passed, "
               f"{f.get('failed', 0)} failed, {f.get('skipped', 0)} skipped"]
        out += [f"          skipped: {skips}"] if skips else []
        out += [f"          failed: {name}" for name in f.get("failures", [])[:MAX_FAILURES_SHOWN]]
        more = len(f.get("failures", [])) - MAX_FAILURES_SHOWN
        return out + ([f"          ... and {more} more (tests.log)"] if more > 0 else [])
    if stage["name"] == "bench":
        out = [f"{head}  {f.get('gl', {}).get('renderer', '')}",
               "          particles    GS/TF frame ms   compute frame ms   compute speedup"]
        out += [f"          {s['particles']:>11,} {_number(s['gs_tf_frame_ms']):>14} "
                f"{_number(s['compute_frame_ms']):>18} {_number(s['compute_speedup'], 'x'):>17}"
                for s in f.get("sizes", [])]
        return out + [f"          not measured: {s['particles']:,} ({s['why']})"
                      for s in f.get("skipped", [])]
    if stage["name"] == "replay":
        return [f"{head}  {stage['detail']}"] + [
            f"          {r['log']}: {r['frames']} frames, "
            f"{'every checksum reproduced' if r['equal'] else r['said']}" for r in f["logs"]]
    barrier = f.get("barrier_ms") or {}
    return [f"{head}  {f.get('walls')} walls, {f.get('frames')} frames, "
            f"{_number(f.get('frames_per_second'))} frames/s, barrier p50 "
            f"{_number(barrier.get('p50'))} ms, {f.get('divergences')} divergences"]


def _number(value, unit: str = "") -> str:
    return "-" if value is None else f"{value:.2f}{unit}"
