"""The harness's table for a person: one row per injected fault."""

from __future__ import annotations

from rich.table import Table


def check_table(report: dict) -> Table:
    final = report["final"]
    table = Table(title=f"cavesim check: {report['frames']} frames, walls "
                        f"{', '.join(report['walls'])}; {report['divergences']} divergence(s); "
                        f"all walls agree at the end: {'yes' if final.get('agree') else 'NO'}")
    for column in ("fault", "detected at", "named", "healed at", "healed", "localised"):
        table.add_column(column)
    for outcome in report["faults"]:
        localisation = outcome.get("localisation")
        table.add_row(outcome["fault"], str(outcome["detected_frame"]),
                      ", ".join(outcome["named"]) or "-", str(outcome["healed_frame"]),
                      "yes" if outcome["healed"] else "[red]NO",
                      "-" if localisation is None else
                      "exactly" if localisation["exact"] else "[red]NO")
    return table
