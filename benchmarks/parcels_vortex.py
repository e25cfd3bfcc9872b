"""Passive tracers in a solid-body vortex, cavesim against OceanParcels 4 (benchmarks/
vortex_case.py: 64³ float32 grid, trilinear, RK4, 60 steps of 1/60 s from a disk of radius
0.8 m, errors against the rotation in closed form).

    python benchmarks/parcels_vortex.py [--sizes 10000,100000,1000000] [--out results.json]
        [--twin-up-to 100000] [--cavesim-only]

Per size, cavesim first (GS/TF, compute, the numpy float32 twin up to --twin-up-to
particles), then Parcels (float32 particles, then float64) where parcels 4 is installed
(pip install 'cavesim[parcels]'): a line per run as it is measured, the tables at the end,
and with --out the JSON of every run, rewritten after each size. The time of a step is the
median over the 60 steps, each timed alone; a speed-up is Parcels' (float32) time per step
over the cavesim path's.
"""

from __future__ import annotations

import sys
from pathlib import Path

if __package__ in (None, ""):  # run as a file: its folder's parent holds `benchmarks`
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import argparse
import importlib.metadata
import json
import os
import tempfile

import numpy as np

from benchmarks import vortex_table as table
from benchmarks.vortex_case import DT, NODES, RADIUS, STEPS, Run, start_positions
from benchmarks.vortex_cavesim import engine_run, twin_run, write_field
from cavesim.core.errors import CavesimError
from cavesim.core.scene.model import Engine
from cavesim.gpu.gl.context import create_context, describe

DEFAULT_SIZES = (10_000, 100_000, 1_000_000)
TWIN_UP_TO = 100_000  # particles: the twin takes about 2 s a step at 1,000,000 on 2 cores
CASE = {"flow": "solid-body vortex about z, 1 rad/s",
        "grid": f"{NODES}^3 float32 nodes over (-1, -1, 0)..(1, 1, 1) m, trilinear",
        "start": f"uniform in a disk of radius {RADIUS} m at z = 0.5 m (seed 3), float32",
        "method": "RK4", "dt_s": DT, "steps": STEPS,
        "step_time": "median over the steps, each timed alone; cavesim's engine paths end "
                     "each step in ctx.finish() (glFinish), Parcels' in one execute() of one dt"}


class OneLineParser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # one line, no usage block
        self.exit(2, f"{self.prog}: {message} (see --help)\n")


def particle_counts(text: str) -> tuple[int, ...]:
    try:
        counts = tuple(int(part) for part in text.split(","))
    except ValueError:
        counts = ()
    if not counts or min(counts) < 1:
        raise argparse.ArgumentTypeError(
            f"particle counts, comma-separated (10000,100000), not {text!r}")
    return counts


def parser() -> argparse.ArgumentParser:
    p = OneLineParser(prog="parcels_vortex.py",
                      description="Passive tracers in a solid-body vortex: cavesim against "
                                  "OceanParcels 4, time per step and error.")
    p.add_argument("--sizes", type=particle_counts, default=DEFAULT_SIZES,
                   help="particle counts, comma-separated (default 10000,100000,1000000)")
    p.add_argument("--out", type=Path, help="write every run as JSON to this file")
    p.add_argument("--twin-up-to", type=int, default=TWIN_UP_TO, metavar="N",
                   help=f"time the numpy twin up to N particles (default {TWIN_UP_TO:,})")
    p.add_argument("--cavesim-only", action="store_true", help="leave Parcels out")
    return p


def parcels_version() -> str | None:
    """The installed parcels 4's version; None (and says why, in one line) otherwise."""
    try:
        version = importlib.metadata.version("parcels")
    except importlib.metadata.PackageNotFoundError:
        print("parcels is not installed (pip install 'cavesim[parcels]'): cavesim alone")
        return None
    if not version.startswith("4."):
        print(f"parcels {version} is installed, this compares with Parcels 4: cavesim alone")
        return None
    return version


def main(argv: list[str] | None = None) -> int:
    arguments = parser()
    args = arguments.parse_args(argv)
    if args.out and not args.out.parent.is_dir():
        arguments.error(f"argument --out: no folder {args.out.parent}")
    version = None if args.cavesim_only else parcels_version()
    try:
        measured = measure(args, version)
    except CavesimError as e:  # no GL context, or a size it cannot hold
        print(f"parcels_vortex.py: {e}", file=sys.stderr)
        return 1
    print()
    print(table.comparison_table(measured))
    print()
    print(table.runs_table(measured))
    return 0


def measure(args: argparse.Namespace, version: str | None) -> list[dict[str, Run]]:
    """Every size's runs, printed as they end; the JSON rewritten after each size."""
    ctx = create_context()
    report = {"case": CASE, "gl": describe(ctx), "parcels": version,
              "cpu_count": os.cpu_count(), "sizes": []}
    print(f"{report['gl']['renderer']}, {report['gl']['version']}; {os.cpu_count()} CPUs; "
          f"Parcels {version or 'not run'}")
    measured: list[dict[str, Run]] = []
    with tempfile.TemporaryDirectory() as folder:
        field_file = write_field(Path(folder))
        fieldset = None
        if version is not None:
            from benchmarks.vortex_parcels import vortex_fieldset

            fieldset = vortex_fieldset()
        for count in args.sizes:
            load = os.getloadavg()
            print(f"{count:,} particles (load average {load[0]:.2f})", flush=True)
            runs = measure_size(ctx, field_file, fieldset, count, args.twin_up_to)
            measured.append(runs)
            report["sizes"].append({"particles": count, "load_average": load,
                                    "runs": {key: run.to_json() for key, run in runs.items()}})
            if args.out:
                args.out.write_text(json.dumps(report, indent=2) + "\n")
    ctx.release()
    return measured


def measure_size(ctx, field_file: Path, fieldset, count: int, twin_up_to: int
                 ) -> dict[str, Run]:
    """Every run at `count` particles, cavesim's first, each printed as it ends."""
    start = start_positions(count)
    runs: dict[str, Run] = {}

    def keep(key: str, run: Run) -> None:
        runs[key] = run
        print(table.run_line(run), flush=True)

    keep(table.GS_TF, engine_run(ctx, field_file, Engine.GS_TF, start))
    keep(table.COMPUTE, engine_run(ctx, field_file, Engine.COMPUTE, start))
    if count <= twin_up_to:
        keep(table.TWIN, twin_run(field_file, start))
    if fieldset is not None:
        from benchmarks.vortex_parcels import parcels_run

        keep(table.PARCELS, parcels_run(fieldset, start, np.float32))
        keep(table.PARCELS_FLOAT64, parcels_run(fieldset, start, np.float64))
    return runs


if __name__ == "__main__":
    sys.exit(main())
