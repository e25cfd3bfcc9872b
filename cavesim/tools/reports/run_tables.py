"""`cavesim run`'s closing tables: the run's figures, where each node's frame went, each
node's GPU, the demo's peaks."""

from __future__ import annotations

from rich.table import Table

from cavesim.core.frame_cost import FRAME_PHASES


def summary_table(report: dict) -> Table:
    rows = [
        ("frames", report["frames"]),
        ("nodes (their walls)", nodes_and_walls(report)),
        *mode_rows(report),
        ("frames per second", report["frames_per_second"]),
        ("barrier p50 / p99 ms", f"{report['barrier_ms']['p50']} / {report['barrier_ms']['p99']}"),
        ("live particles (last / max)",
         f"{report['live_particles']['last']:,} / {report['live_particles']['max']:,}"),
        *drop_rows(report.get("capacity_drops", {})),
        *exit_rows(report.get("domain_exits", {})),
        *substep_rows(report.get("tracer_substeps", {})),
        ("lost for good", ", ".join(report["final"].get("lost", ())) or "none"),
        ("divergences", report["event_totals"]["divergences"]),
        ("resyncs", report["event_totals"]["resyncs"]),
        ("stalls", report["event_totals"]["stalls"]),
        ("rejected messages", sum(report["rejected_messages"]["master"].values())
         + sum(report["rejected_messages"]["nodes"].values())),
    ]
    return _table("cavesim run", rows)


def drop_rows(drops: dict) -> list[tuple[str, str]]:
    """The new particles the full capacity dropped, from the first frame it did."""
    if not drops:
        return []
    held = f"capacity {drops['capacity']:,}"
    if not drops["total"]:
        return [("dropped at capacity", f"none ({held})")]
    return [("dropped at capacity",
             f"{drops['total']:,} from frame {drops['first_frame']} ({held})")]


def exit_rows(exits: dict) -> list[tuple[str, str]]:
    """Who left the field's box, per class, from the first frame one did (a grid's flow)."""
    if not exits:
        return []
    left = ", ".join(f"{exits['total'][name]:,} {name} from frame {exits['first_frame'][name]}"
                     for name in exits["classes"] if exits["total"][name]) or "none"
    if exits["frames_uncounted"]:
        left += f" ({exits['frames_uncounted']:,} frames not counted)"
    return [("left the field's box", left)]


def substep_rows(substeps: dict) -> list[tuple[str, str]]:
    """What the adaptive tracers' substeps came to (a scene whose tracers take them)."""
    if not substeps:
        return []
    if not substeps["tracer_frames"]:
        return [("tracer substeps", "no tracer stepped")]
    taken = (f"{substeps['per_tracer_frame']} a tracer a frame, {substeps['retaken']:,} "
             f"retaken, at most {substeps['most']} (frame {substeps['most_frame']})")
    if substeps["frames_uncounted"]:
        taken += f" ({substeps['frames_uncounted']:,} frames not counted)"
    return [("tracer substeps", taken)]


def nodes_and_walls(report: dict) -> str:
    """Each node, and in brackets the walls it draws where they are not just its own."""
    drawn = report.get("walls_of_nodes", {})
    return ", ".join(node if drawn.get(node, [node]) == [node]
                     else f"{node} ({' '.join(drawn[node])})" for node in report["nodes"])


def mode_rows(report: dict) -> list[tuple[str, str]]:
    """How the walls were compared: bit-exact, or the mixed-hardware tolerance mode with its
    settings, breaches and the worst drift seen."""
    tolerance = report.get("tolerance")
    if tolerance is None:
        return [("mode", f"{report['mode']} ({report['arithmetic']} arithmetic)")]
    worst = [d["worst"] for d in tolerance["drift"].values()]
    position = max((w["position_max_m"] for w in worst if w["position_max_m"] is not None),
                   default=0.0)
    velocity = max((w["velocity_max_m_s"] for w in worst if w["velocity_max_m_s"] is not None),
                   default=0.0)
    return [("mode", f"{report['mode']} (authority {tolerance['authority']}, "
                     f"{report['arithmetic']} arithmetic)"),
            ("resync every / sample", f"{tolerance['resync_every_frames']} frames / "
                                      f"{tolerance['sample_records']} records"),
            ("tolerance (position / velocity)", f"{tolerance['position_tolerance_m']:g} m / "
                                                f"{tolerance['velocity_tolerance_m_s']:g} m/s"),
            ("breaches / periodic resyncs",
             f"{tolerance['breach_total']} / {tolerance['periodic_resyncs']}"),
            ("worst drift (position / velocity)", f"{position:g} m / {velocity:g} m/s")]


def forensic_lines(report: dict, shown: int = 10) -> list[str]:
    """What differed at each divergence (the first `shown`), as the master's forensics found
    it, and where the whole report is."""
    explained = [d["forensics"] for d in report["divergences"] if d.get("forensics")]
    lines = [f"{f['summary']} ({f['file']})" for f in explained[:shown]]
    if len(explained) > shown:
        lines.append(f"... and {len(explained) - shown} more in divergences/")
    return lines


def gpu_table(report: dict) -> Table:
    """What each node computed on, and with which engine path, as it told the master."""
    table = Table(title="GPUs")
    for column in ("node", "EGL device", "renderer", "OpenGL version (driver)", "engine"):
        table.add_column(column)
    for wall in report["nodes"]:
        gpu = report["gpus"].get(wall)
        if gpu is None:
            table.add_row(wall, "?", "did not answer the info query", "", "")
        else:
            engine = f"{gpu['engine']} (probed)" if gpu["engine_probed"] else gpu["engine"]
            table.add_row(wall, f"{gpu['device']} ({gpu['kind']})", gpu["renderer"],
                          gpu["version"], engine)
    return table


def frame_cost_table(report: dict) -> Table:
    """Where each node's frame went: p50 / p99 ms of each phase its reports timed."""
    table = Table(title="where each node's frame went (p50 / p99 ms)")
    table.add_column("phase")
    table.add_column("clock")
    costs = report["frame_cost_ms"]
    for node in costs:
        table.add_column(node, justify="right")
    for phase, (clock, _) in FRAME_PHASES.items():
        table.add_row(phase, clock, *(_p50_p99(cost[phase]) for cost in costs.values()))
    # the render row's p50 is 0 where a node draws every Kth frame: this one's is not
    drawn = report.get("render_ms_per_wall", {})
    table.add_row("render per wall, drawn frames", "CPU",
                  *(_p50_p99(drawn[node]) if node in drawn else "-" for node in costs))
    return table


def _p50_p99(percentiles: dict) -> str:
    return " / ".join("-" if (ms := percentiles[q]) is None else f"{ms:.2f}"
                      for q in ("p50", "p99"))


def demo_table(report: dict) -> Table:
    """The helicopter's figures: peaks of the dust, the altitude they came at."""
    from cavesim.tools.reports.demo import demo_summary

    return _table("brownout demo", demo_summary(report))


def _table(title: str, rows) -> Table:
    table = Table(title=title)
    table.add_column("figure")
    table.add_column("value", justify="right")
    for name, value in rows:
        table.add_row(name, str(value))
    return table
