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
        *counter_rows(report.get("counters", {})),
        ("lost for good", ", ".join(report["final"].get("lost", ())) or "none"),
        ("divergences", report["event_totals"]["divergences"]),
        ("resyncs", report["event_totals"]["resyncs"]),
        ("stalls", report["event_totals"]["stalls"]),
        ("lags past --max-lag", report["event_totals"].get("lags", 0)),
        ("rejected messages", sum(report["rejected_messages"]["master"].values())
         + sum(report["rejected_messages"]["nodes"].values())),
    ]
    return _table("cavesim run", rows)


def counter_rows(counters: dict) -> list[tuple[str, str]]:
    """One row per counter of report.json's `counters` (cavesim/core/counters.py's rows, as
    the master kept them): its total from its first frame, or its largest and when; and
    whose values they are where not the walls' agreed ones."""
    rows = [(entry["label"], counter_text(entry)) for entry in counters.values()
            if isinstance(entry, dict) and "label" in entry]
    if rows and counters.get("values_from", "agreed") != "agreed":
        rows.append(("counters from", f"the {counters['values_from']} (mixed hardware)"))
    return rows


def counter_text(entry: dict) -> str:
    """A counter's row: per class or per value what it came to, and the frames not counted."""
    names = entry.get("classes")
    if "total" in entry:
        parts = [f"{total:,} {name}" + (f" from frame {first}" if first is not None else "")
                 for name, total, first in _values(entry, "total", "first_frame", names)
                 if total]
    else:
        parts = [f"at most {largest:,} {name} (frame {frame})"
                 for name, largest, frame in _values(entry, "largest", "largest_frame", names)
                 if largest]
    text = ", ".join(parts) or "none"
    missed = [f"{entry[key]:,} frames {what}" for key, what in (
        ("frames_not_counted", "not counted"), ("frames_unagreed", "without agreement"))
        if entry.get(key)]
    return text + (f" ({', '.join(missed)})" if missed else "")


def _values(entry: dict, value_key: str, frame_key: str, names: list[str] | None):
    """(name, value, frame) of each value: a class's by its name, a single value's by the
    counter's unit."""
    values, frames = entry[value_key], entry.get(frame_key)
    if names is not None:
        return [(name, values[name], frames[name] if frames else None) for name in names]
    if not isinstance(values, list):
        return [(entry["unit"], values, frames)]
    return [(f"{entry['unit']} [{i}]", value, frames[i] if frames else None)
            for i, value in enumerate(values)]


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
