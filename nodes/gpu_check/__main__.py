"""`python -m nodes.gpu_check [--out DIR] [--tests full|fast|none] [--quick]`: the check,
stage by stage, each line printed as it happens; exit 0 only when every stage passed."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from cavesim.core.errors import CavesimError
from cavesim.tools.signals import stop_signals
from nodes.arguments import INTERRUPTED, RUN_ERROR, USAGE_ERROR
from nodes.gpu_check import stages as run
from nodes.gpu_check.summary import lines, report, write


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="deploy/gpu-check.sh", description="check this GPU node end to end: doctor, "
        "tests, bench, shipped frame logs replayed bit for bit, the 4-wall demo")
    parser.add_argument("--out", type=Path, default=Path("out/gpu-check"),
                        help="folder for gpu-check.json and every stage's log "
                             "(default: out/gpu-check)")
    parser.add_argument("--tests", choices=run.TEST_TIERS,
                        help="the whole suite, its fast tier (no tests marked slow) or none "
                             "(default: full on a GPU, fast on a software renderer or "
                             "with --quick)")
    parser.add_argument("--quick", action="store_true",
                        help=f"a few minutes anywhere: the bench's --quick, the demo's first "
                             f"{run.QUICK_DEMO_FRAMES} frames, the suite's fast tier")
    args = parser.parse_args(argv)
    if args.out.exists() and not args.out.is_dir():
        print(f"gpu-check: error: --out {str(args.out)!r} is a file, not a folder",
              file=sys.stderr)
        return USAGE_ERROR
    args.out.mkdir(parents=True, exist_ok=True)
    started, done, ended = time.monotonic(), [], "complete"

    def say(text: str) -> None:
        print(f"[{time.monotonic() - started:6.0f} s] {text}", flush=True)

    try:
        with stop_signals():
            for step in _steps(args, say):
                stage = step()
                done.append(stage)
                say(f"{stage.name}: {stage.ended} in {stage.seconds:.0f} s  {stage.detail}")
    except KeyboardInterrupt:
        ended = "interrupted"
    except (CavesimError, OSError) as e:
        ended = f"error: {e}"
    found = report(done, ended)
    path = args.out / "gpu-check.json"
    write(found, path)
    print("\n".join(lines(found)))
    print(f"wrote {path}")
    if ended == "interrupted":
        return INTERRUPTED
    return 0 if found["ok"] else RUN_ERROR


def _steps(args: argparse.Namespace, say: run.Say):
    """The stages in order; the whole suite where the doctor opened a hardware device,
    its fast tier elsewhere or with --quick, unless --tests says."""
    doctor = run.doctor(args.out, say)
    yield lambda: doctor
    kinds = doctor.figures.get("kinds", [])
    tier = args.tests or ("full" if "hardware" in kinds and not args.quick else "fast")
    yield lambda: run.tests(args.out, tier, say)
    yield lambda: run.bench(args.out, say, args.quick)
    yield lambda: run.replays(args.out, say)
    yield lambda: run.demo(args.out, say, run.QUICK_DEMO_FRAMES if args.quick
                           else run.DEMO_FRAMES)


if __name__ == "__main__":
    sys.exit(main())
