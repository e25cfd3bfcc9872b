"""`cavesim stability`: the stiff sweep and the extreme cases, as JSON, markdown and a map."""

from __future__ import annotations

import json
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from cavesim.core.scene import Integrator  # noqa: E402
from cavesim.tools.stability.extremes import run_extremes  # noqa: E402
from cavesim.tools.stability.sweep import (  # noqa: E402
    DRAG_CASES,
    STEPS,
    run_sweep,
)


def run_stability(ctx, out_dir: Path, frames: int = 120) -> dict:
    """Run both parts; write stability.json, stability.md and stability.png into out_dir."""
    out_dir.mkdir(parents=True, exist_ok=True)
    sweep = run_sweep(ctx, frames)
    extremes = run_extremes(ctx)
    report = {
        "command": "stability",
        "sweep": sweep,
        "sweep_agrees_with_theory": all(r["agrees"] for r in sweep),
        "extremes": extremes,
        "nan_free": all(r["state_finite"] for r in sweep + extremes),
        "limits": {i.value: i.stability_limit for i in Integrator},
    }
    (out_dir / "stability.json").write_text(json.dumps(report, indent=2, default=str) + "\n")
    (out_dir / "stability.md").write_text(markdown(report))
    plot(sweep, out_dir / "stability.png")
    return report


def markdown(report: dict) -> str:
    lines = ["# cavesim stability", "", "## Stiff sweep: drag, tau from 10 s to 1 µs",
             "", "Largest bounded stiffness h = dt·lambda (dt/tau for Stokes drag) on the GPU "
             "against the theoretical limit (120 frames; particles that run away are dropped, "
             "never stored). For Schiller-Naumann drag h is given from the settling slip to "
             "the largest starting slip: a class whose range crosses the limit is marginal "
             "(either outcome agrees with theory).", "",
             "| drag | integrator | dt | theory: stable for h < | largest bounded h "
             "| smallest divergent h | marginal | agrees |",
             "|---|---|---:|---:|---:|---:|---:|---|"]
    for drag in DRAG_CASES:
        for integrator in Integrator:
            for dt in STEPS:
                rows = [r for r in report["sweep"] if r["drag"] == drag.name
                        and r["integrator"] == integrator.value and r["dt"] == dt]
                bounded = [r for r in rows if r["outcome"] == "bounded"]
                divergent = [r for r in rows if r["outcome"] == "divergent"]
                limit = integrator.stability_limit
                largest = max(bounded, key=lambda r: r["stiffness"], default=None)
                smallest = min(divergent, key=lambda r: r["stiffness"], default=None)
                lines.append(f"| {drag.name} | {integrator.value} | 1/{round(1 / dt)} | "
                             f"{'any' if np.isinf(limit) else limit} | "
                             f"{stiffness_text(largest) if largest else 'none'} | "
                             f"{stiffness_text(smallest) if smallest else 'none'} | "
                             f"{sum(r['theory'] == 'marginal' for r in rows)} | "
                             f"{'yes' if all(r['agrees'] for r in rows) else 'NO'} |")
    lines += ["", "## Extreme cases", "", "| case | outcome | what the user sees | state finite |",
              "|---|---|---|---|"]
    for r in report["extremes"]:
        lines.append(f"| {r['case']} | {r['outcome']} | {r['user_sees']} | "
                     f"{'yes' if r['state_finite'] else 'NO'} |")
    return "\n".join(lines) + "\n"


def stiffness_text(row: dict) -> str:
    """h, or h at the settling slip – h at the largest starting slip where they differ."""
    low, high = row["stiffness"], row["stiffness_max"]
    return f"{low:.3g}" if high <= low * 1.0001 else f"{low:.3g}–{high:.3g}"


def plot(sweep: list[dict], path: Path) -> None:
    """The map: integrators against dt/tau, bounded (green) or divergent (red), with the
    theoretical limits as bars."""
    lines = [(d.name, i) for d in DRAG_CASES for i in Integrator]
    fig, ax = plt.subplots(figsize=(10, 1.2 + 0.45 * len(lines)), dpi=100)
    for row in sweep:
        y = lines.index((row["drag"], Integrator(row["integrator"]))) \
            + (0.12 if row["dt"] == STEPS[1] else -0.12)
        colour = "tab:green" if row["outcome"] == "bounded" else "tab:red"
        if row["stiffness_max"] > row["stiffness"]:  # the slip's range of h
            ax.plot([row["stiffness"], row["stiffness_max"]], [y, y], c=colour, lw=0.8,
                    alpha=0.5)
        ax.scatter(row["stiffness"], y, c=colour, s=18, marker="o" if row["agrees"] else "x")
    for k, (_, integrator) in enumerate(lines):
        limit = integrator.stability_limit
        if np.isfinite(limit):
            ax.plot([limit, limit], [k - 0.35, k + 0.35], c="k", lw=1.5)
    ax.set_xscale("log")
    names = [i.value if len(DRAG_CASES) == 1 else f"{d} {i.value}" for d, i in lines]
    ax.set_yticks(range(len(names)), names)
    ax.set_xlabel("stiffness h = dt · lambda (dt / tau for Stokes drag)\nSchiller-Naumann: "
                  "dot at the settling slip, line to the largest starting slip")
    ax.set_title("Drag on the GPU: bounded (green) or divergent (red); black bar: "
                 "theory's limit")
    ax.grid(True, axis="x", alpha=0.3)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
