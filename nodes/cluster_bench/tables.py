"""How the cluster benchmark shows itself: the rich tables, the markdown file, the JSON."""

from __future__ import annotations

import json
from pathlib import Path

from rich.console import Console
from rich.table import Table

from cavesim.core.frame_cost import FRAME_PHASES
from cavesim.tools.bench.display import TARGET_STYLES

BARRIER_HEADERS = ("nodes", "p50 ms", "p99 ms", "max ms", "cpu ms/frame", "cpu floor ms",
                   "frames/s", "live max", "divergences")
SWAP_HEADERS = ("walls", "skew p50 ms", "skew p99 ms", "skew max ms", "frames",
                "order violations", "stalls", "incomplete", "barrier p99 ms", "frames/s")
LOCKSTEP_HEADERS = ("walls", "cluster frames/s", "back-to-back frames/s", "lock-step cost",
                    "same final checksum")


def _ms(value: float | None) -> str:
    return "-" if value is None else f"{value:.3f}"


def barrier_rows(report: dict) -> list[tuple[str, ...]]:
    return [(str(run["nodes"]), *(_ms(run["barrier_ms"][q]) for q in ("p50", "p99", "max")),
             _ms((run["cpu_ms_per_frame"] or {}).get("total")), _ms(run["cpu_floor_ms"]),
             f"{run['frames_per_second']:.1f}", f"{run['live_particles_max']:,}",
             str(run["divergences"])) for run in report["barrier"]["runs"]]


def cost_headers(report: dict) -> tuple[str, ...]:
    return ("phase", "clock", *(f"{run['nodes']} nodes ms" for run in _costed(report)))


def cost_rows(report: dict) -> list[tuple[str, ...]]:
    """Per phase, where a node's frame went in each barrier run: p50 / p99 of the node
    slowest in it (the barrier waits for the slowest); last, the master's barrier (publish
    to every report in)."""
    def cell(cost: dict, phase: str) -> str:
        return " / ".join(_ms(max((node[phase][q] for node in cost.values()
                                   if node[phase][q] is not None), default=None))
                          for q in ("p50", "p99"))
    runs = _costed(report)
    return [*((phase, clock, *(cell(run["frame_cost_ms"], phase) for run in runs))
              for phase, (clock, _) in FRAME_PHASES.items()),
            ("barrier (master)", "CPU", *(" / ".join(_ms(run["barrier_ms"][q])
                                                     for q in ("p50", "p99")) for run in runs))]


def _costed(report: dict) -> list[dict]:
    return [run for run in report["barrier"]["runs"] if run["frame_cost_ms"]]


def swap_rows(report: dict) -> list[tuple[str, ...]]:
    return [(str(run["nodes"]), *(_ms(run["swap"]["skew_ms"][q]) for q in ("p50", "p99", "max")),
             str(run["swap"]["frames"]), str(run["swap"]["order_violations"]),
             str(run["swap"]["stalls_total"]), str(run["swap"]["incomplete"]),
             _ms(run["barrier_ms"]["p99"]), f"{run['frames_per_second']:.1f}")
            for run in report["swap"].get("runs", ())]


def swap_title(report: dict) -> str:
    swap = report["swap"]
    if "skipped" in swap:
        return f"swap barrier - skipped: {swap['skipped']}"
    return (f"swap barrier - {swap['scene']}, {swap['window_px']} px windows on "
            f"{swap['x_server']}, {report['frames']} frames")


def one_node_line(report: dict) -> str:
    """What a node's own work takes of the round trip, measured in this process."""
    ms = report["barrier"]["one_node"]["frame_ms"]
    return (f"one node's step + checksum of the same frames in one process: p50 "
            f"{ms['p50']:.3f} ms, p99 {ms['p99']:.3f} ms")


def lockstep_row(report: dict) -> tuple[str, ...]:
    step = report["lockstep"]
    return (str(step["walls"]), f"{step['cluster_fps']:.1f}", f"{step['back_to_back_fps']:.1f}",
            f"{step['lockstep_cost']:.1%}", "yes" if step["same_final_checksum"] else "NO")


def target_line(target: dict) -> str:
    """'barrier_p99_ms <= 2 ms with 4 nodes: measured 3.412 ms - NOT met'."""
    measured = (f"{target['measured']:.1%}" if target["name"] == "lockstep_cost"
                else f"{target['measured']:.3f} ms")
    verdict = {True: "met", False: "NOT met", None: f"not judged ({target.get('why')})"}[
        target["met"]]
    bound = f"{target['target']:.0%}" if target["name"] == "lockstep_cost" else \
        f"{target['target']:g} ms"
    return (f"{target['name']} {target['comparison']} {bound} with {target['nodes']} nodes: "
            f"measured {measured} - {verdict}")


def show(report: dict, console: Console) -> None:
    scenes = report["barrier"]["scene"], report["lockstep"]["cluster"]["scene"]
    for title, headers, rows in (
            (f"barrier round trip - {scenes[0]}, {report['frames']} frames", BARRIER_HEADERS,
             barrier_rows(report)),
            ("where a node's frame goes (p50 / p99, the slowest node)", cost_headers(report),
             cost_rows(report)),
            (swap_title(report), SWAP_HEADERS, swap_rows(report)),
            (f"lock-step vs back to back - {scenes[1]}, {report['frames']} frames",
             LOCKSTEP_HEADERS, [lockstep_row(report)])):
        table = Table(title=title)
        for header in headers:
            table.add_column(header, justify="right")
        for row in rows:
            table.add_row(*row)
        console.print(table)
        if headers is BARRIER_HEADERS:
            console.print(one_node_line(report))
    console.print("targets:")
    for target in report["targets"]:
        console.print(f"  {target_line(target)}", style=TARGET_STYLES[target["met"]],
                      soft_wrap=True)  # one line, however long, for a log or a grep


def _markdown_table(headers: tuple[str, ...], rows: list[tuple[str, ...]]) -> list[str]:
    return ["| " + " | ".join(headers) + " |", "|" + "|".join("---:" for _ in headers) + "|",
            *("| " + " | ".join(row) + " |" for row in rows)]


def markdown(report: dict) -> str:
    gl = report["gl"]
    lines = ["# cavesim bench --cluster", "",
             f"{gl['renderer']} ({gl['version']}), {report['cpu_count']} CPUs, "
             f"{report['frames']} frames per run, {report['created']}", "",
             f"## Barrier round trip ({report['barrier']['scene']})", "",
             *_markdown_table(BARRIER_HEADERS, barrier_rows(report)), "",
             one_node_line(report), "",
             "## Where a node's frame goes (p50 / p99 ms, the slowest node)", "",
             *_markdown_table(cost_headers(report), cost_rows(report)), "",
             *(f"- {phase} ({clock}): {meaning}"
               for phase, (clock, meaning) in FRAME_PHASES.items()), "",
             f"## {swap_title(report)}", "",
             *(_markdown_table(SWAP_HEADERS, swap_rows(report)) if swap_rows(report) else []),
             "",
             f"## Lock-step vs back to back ({report['lockstep']['cluster']['scene']})", "",
             *_markdown_table(LOCKSTEP_HEADERS, [lockstep_row(report)]), "",
             "## Targets", "", *(f"- {target_line(t)}" for t in report["targets"]), "",
             "## Notes", "", *(f"- {note}" for note in report["notes"])]
    return "\n".join(lines) + "\n"


def write_reports(report: dict, out_dir: Path) -> list[Path]:
    """Write cluster.json and cluster.md into `out_dir`; return their paths."""
    out_dir.mkdir(parents=True, exist_ok=True)
    json_path, md_path = out_dir / "cluster.json", out_dir / "cluster.md"
    json_path.write_text(json.dumps(report, indent=2) + "\n", encoding="utf-8")
    md_path.write_text(markdown(report), encoding="utf-8")
    return [json_path, md_path]
