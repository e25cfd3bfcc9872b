"""The brownout demo's figures: plots and closing-table rows from a run's report.

`cavesim run` calls this after the master has written report.json (and the walls have
been assembled): the report's "flight" list (one entry per frame of a helicopter scene:
t, altitude, rotor_speed, induced_velocity, emission_rate) and "live_per_frame" (the
live count after each frame) become two PNGs under out/plots and a few summary rows; the
new particles the full capacity dropped (the counter "capacity_drops" of "counters") share
the emission's axis.
A run longer than 4,096 frames keeps every n-th frame of each ("flight_frames_stride",
"live_frames_stride"). A scene without a helicopter has an empty flight list and gets
neither.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib
import numpy as np

from cavesim.core.output import writing

matplotlib.use("Agg")  # headless: no display on the master's host, and no GUI event loop
import matplotlib.pyplot as plt  # noqa: E402  (must follow the backend choice)
from matplotlib.ticker import StrMethodFormatter  # noqa: E402

WIDTH_IN, DPI = 10.0, 100  # 1000 px wide
THOUSANDS = StrMethodFormatter("{x:,.0f}")
ALTITUDE_COLOUR, LIVE_COLOUR, EMISSION_COLOUR = "tab:green", "tab:blue", "tab:red"
DROPPED_COLOUR = "tab:purple"
ALTITUDE_CHANGE = 1.0  # m of the skids' altitude: less is hovering, for the plot's title
LANDED = 0.2  # m: the skids this close to the ground stand on it


def _series(report: dict) -> dict[str, np.ndarray]:
    """The flight log as arrays, at the frames both it and the live counts kept; `live`
    pairs a frame's count with the flight entry of the same frame."""
    flight_stride = report.get("flight_frames_stride", 1)
    live_stride = report.get("live_frames_stride", 1)
    stride = max(flight_stride, live_stride)  # powers of 2: a multiple of both
    flight = (report.get("flight") or [])[stride // flight_stride - 1::stride // flight_stride]
    live = np.asarray(report.get("live_per_frame") or [], dtype=float)
    live = live[stride // live_stride - 1::stride // live_stride]
    n_live = min(len(live), len(flight))  # an interrupted run logs one flight entry more
    return {"t": np.array([f["t"] for f in flight], dtype=float),
            "altitude": np.array([f["altitude"] for f in flight], dtype=float),
            "emission": np.array([f["emission_rate"] for f in flight], dtype=float),
            "live": live[:n_live], **_drops(report)}


def _drops(report: dict) -> dict[str, np.ndarray]:
    """Dropped particles per second and the end time of each bin they were summed over
    (none in a run that dropped none, or a report from before they were counted so), and
    the capacity."""
    counters = report.get("counters") or {}
    drops = counters.get("capacity_drops") or {}
    sums = np.asarray(drops.get("per_frame", ()), dtype=float)
    if not len(sums):
        return {"dropped_t": sums, "dropped": sums, "capacity": None}
    stride, frame_seconds = drops["per_frame_stride"], counters["frame_seconds"]
    ends = np.minimum(np.arange(1, len(sums) + 1) * stride, report["frames"])
    held = ends - np.arange(len(sums)) * stride  # frames in each bin: the last may hold fewer
    return {"dropped_t": ends * frame_seconds, "dropped": sums / (held * frame_seconds),
            "capacity": report.get("capacity")}


def write_demo_plots(report: dict, out_dir: Path) -> list[Path]:
    """Write out_dir/plots/*.png from the report's flight log; [] when it has none."""
    if not report.get("flight"):
        return []
    s = _series(report)
    plots = Path(out_dir) / "plots"
    plots.mkdir(parents=True, exist_ok=True)
    paths = [plots / "live_and_emission_vs_time.png", plots / "emission_vs_altitude.png"]
    for path, draw in zip(paths, (_plot_against_time, _plot_against_altitude), strict=True):
        fig = draw(s)
        try:
            with writing(path):
                fig.savefig(path, dpi=DPI)
        finally:
            plt.close(fig)
    return paths


def flight_story(altitude: np.ndarray) -> str:
    """What the helicopter did, read from its altitude: "descends, lands and lifts off" for
    the scripted demo, "hovers" for a steady hand, and so on."""
    low = int(np.argmin(altitude))
    lowest = float(altitude[low])
    moves = []
    if altitude[0] - lowest > ALTITUDE_CHANGE:
        moves.append("descends")
    if lowest < LANDED:
        moves.append("lands")
    if altitude[low:].max() - lowest > ALTITUDE_CHANGE:
        moves.append("lifts off" if lowest < LANDED else "climbs")
    if not moves:
        return "hovers"
    return moves[0] if len(moves) == 1 else f"{', '.join(moves[:-1])} and {moves[-1]}"


def _plot_against_time(s: dict[str, np.ndarray]):
    """Altitude above, live particles and emission rate below, on one time axis."""
    fig, (top, bottom) = plt.subplots(2, 1, sharex=True, figsize=(WIDTH_IN, 7.0),
                                      height_ratios=(1.0, 1.6), layout="constrained")
    fig.suptitle(f"Brownout: dust raised as the helicopter {flight_story(s['altitude'])}",
                 fontsize=14)
    top.plot(s["t"], s["altitude"], color=ALTITUDE_COLOUR, lw=2)
    top.fill_between(s["t"], s["altitude"], color=ALTITUDE_COLOUR, alpha=0.15)
    top.set_ylabel("altitude, skids\nabove ground (m)")
    top.set_ylim(bottom=0.0)
    top.grid(alpha=0.3)

    lines = bottom.plot(s["t"][:len(s["live"])], s["live"], color=LIVE_COLOUR, lw=2,
                        label="live particles")
    if s["capacity"] is not None:
        lines.append(bottom.axhline(s["capacity"], color=LIVE_COLOUR, ls="--", lw=1,
                                    label=f"capacity, {s['capacity']:,}"))
    bottom.set_ylabel("live particles", color=LIVE_COLOUR)
    bottom.tick_params(axis="y", labelcolor=LIVE_COLOUR)
    bottom.set_ylim(bottom=0.0)
    bottom.yaxis.set_major_formatter(THOUSANDS)
    bottom.set_xlabel("time (s)")
    bottom.grid(alpha=0.3)
    rate = bottom.twinx()
    lines += rate.plot(s["t"], s["emission"], color=EMISSION_COLOUR, lw=1.5,
                       label="emission rate")
    if len(s["dropped"]):
        lines += rate.plot(s["dropped_t"], s["dropped"], color=DROPPED_COLOUR, lw=1.5,
                           drawstyle="steps-pre", label="dropped at capacity")
    rate.set_ylabel("emission rate (particles/s)", color=EMISSION_COLOUR)
    rate.tick_params(axis="y", labelcolor=EMISSION_COLOUR)
    rate.set_ylim(bottom=0.0)
    rate.yaxis.set_major_formatter(THOUSANDS)

    peak = s["t"][int(np.argmax(s["emission"]))]
    top.axvline(peak, color="grey", ls=":", lw=1)
    lines.append(bottom.axvline(peak, color="grey", ls=":", lw=1,
                                label=f"peak emission, t = {peak:.1f} s"))
    bottom.legend(handles=lines, loc="upper left", fontsize=10)
    return fig


def _plot_against_altitude(s: dict[str, np.ndarray]):
    """Emission rate and live particles against altitude, each point coloured by time."""
    fig, (left, right) = plt.subplots(1, 2, figsize=(WIDTH_IN, 4.8), layout="constrained")
    fig.suptitle("Brownout: what the altitude does to the dust", fontsize=14)
    n_live = len(s["live"])
    panels = ((left, s["altitude"], s["emission"], s["t"], "emission rate (particles/s)"),
              (right, s["altitude"][:n_live], s["live"], s["t"][:n_live], "live particles"))
    points = None
    for ax, x, y, t, label in panels:
        ax.plot(x, y, color="lightgrey", lw=0.8, zorder=1)  # the path, in time order
        points = ax.scatter(x, y, c=t, cmap="viridis", s=6, zorder=2,
                            vmin=s["t"].min(), vmax=s["t"].max())
        ax.set_xlabel("altitude, skids above ground (m)")
        ax.set_ylabel(label)
        ax.set_title(f"{label.split(' (')[0]} against altitude", fontsize=12)
        ax.set_xlim(left=0.0)
        ax.set_ylim(bottom=0.0)
        ax.yaxis.set_major_formatter(THOUSANDS)
        ax.grid(alpha=0.3)
    fig.colorbar(points, ax=(left, right), label="time (s)")
    return fig


def demo_summary(report: dict) -> list[tuple[str, str]]:
    """Rows (figure, value) for the closing table of a helicopter run; [] without one."""
    if not report.get("flight"):
        return []
    s = _series(report)
    rows = []
    if len(s["live"]):
        i = int(np.argmax(s["live"]))
        rows.append(("peak live particles", f"{int(s['live'][i]):,} at t = {s['t'][i]:.2f} s"))
    else:  # a report from before live_per_frame: the maximum without its time
        rows.append(("peak live particles", f"{report['live_particles']['max']:,}"))
    i = int(np.argmax(s["emission"]))
    rows.append(("peak emission rate", f"{s['emission'][i]:,.0f} particles/s at "
                 f"{s['altitude'][i]:.2f} m altitude (t = {s['t'][i]:.2f} s)"))
    low = int(np.argmin(s["altitude"]))
    rows.append(("lowest altitude", f"{s['altitude'][low]:.2f} m at t = {s['t'][low]:.2f} s"))
    rows.append(("emission rate: lowest altitude / start",
                 f"{s['emission'][low]:,.0f} / {s['emission'][0]:,.0f} particles/s"))
    fps = report.get("frames_per_second")
    rows += [("frames", f"{report['frames']:,}"),
             ("frames per second", "-" if fps is None else f"{fps}"),
             ("divergences", str(report["event_totals"]["divergences"]))]
    return rows
