"""The printed results of benchmarks/parcels_vortex.py: a line per run as it is measured,
and the tables (markdown) at the end."""

from __future__ import annotations

from benchmarks.vortex_case import Run

PARCELS, PARCELS_FLOAT64 = "parcels_float32", "parcels_float64"
GS_TF, COMPUTE, TWIN = "gs_tf", "compute", "twin"
MISSING = "-"


def run_line(run: Run) -> str:
    return (f"  {run.tool:<28} {run.step_s:10.5f} s/step {run.rate:14,.0f} particles/s   "
            f"RMS {run.rms_m:.2e} m, max {run.max_m:.2e} m")


def comparison_table(sizes: list[dict[str, Run]]) -> str:
    """Side by side per size: Parcels (float32) and both engine paths, each path's speed-up
    over Parcels (Parcels' s/step / the path's), and every RMS error."""
    lines = ["| particles | Parcels s/step | cavesim GS/TF s/step (speed-up) "
             "| cavesim compute s/step (speed-up) | RMS Parcels | RMS GS/TF | RMS compute |",
             "|---:|---:|---:|---:|---:|---:|---:|"]
    for runs in sizes:
        parcels = runs.get(PARCELS)
        cells = [f"{runs[GS_TF].particles:,}", _seconds(parcels)]
        cells += [f"{_seconds(runs[path])} ({_speed_up(parcels, runs[path])})"
                  for path in (GS_TF, COMPUTE)]
        cells += [_error(runs.get(key)) for key in (PARCELS, GS_TF, COMPUTE)]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def runs_table(sizes: list[dict[str, Run]]) -> str:
    """Every run: the float64 Parcels and the numpy twin besides the compared ones."""
    lines = ["| particles | tool | s/step | particles/s | RMS error | max error |",
             "|---:|---|---:|---:|---:|---:|"]
    for runs in sizes:
        lines += [f"| {run.particles:,} | {run.tool} | {run.step_s:.3g} | {run.rate:,.0f} "
                  f"| {run.rms_m:.2e} m | {run.max_m:.2e} m |" for run in runs.values()]
    return "\n".join(lines)


def _seconds(run: Run | None) -> str:
    return MISSING if run is None else f"{run.step_s:.3g}"


def _speed_up(parcels: Run | None, path: Run) -> str:
    return MISSING if parcels is None else f"{parcels.step_s / path.step_s:.1f}x"


def _error(run: Run | None) -> str:
    return MISSING if run is None else f"{run.rms_m:.2e} m"
