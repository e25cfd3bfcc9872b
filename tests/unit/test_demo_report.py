"""The brownout demo's plots and summary rows, from synthetic reports (no cluster)."""

import numpy as np
import pytest
from PIL import Image
from rich.console import Console

from cavesim.tools.reports.demo import _drops, demo_summary, flight_story, write_demo_plots
from cavesim.tools.reports.run_tables import demo_table
from nodes.commands.run import write_plots

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def flight_report(frames: int = 120, dt: float = 0.1) -> dict:
    """Descend from 20 m to the ground at frame 60, sit until 80, climb away; the dust
    follows the altitude, live particles lag behind and peak at frame 90."""
    t = np.arange(1, frames + 1) * dt
    altitude = np.interp(np.arange(frames), [0, 60, 80, frames - 1], [20.0, 0.0, 0.0, 15.0])
    emission = 6000.0 * np.exp(-altitude / 5.0)
    emission[70] = 7000.0  # the peak: on the ground, after the touchdown
    live = np.interp(np.arange(frames), [0, 90, frames - 1], [0, 150_000, 80_000]).astype(int)
    flight = [{"t": round(float(ti), 4), "altitude": round(float(a), 3), "rotor_speed": 1.0,
               "induced_velocity": 10.0, "emission_rate": round(float(e), 1)}
              for ti, a, e in zip(t, altitude, emission, strict=True)]
    return {"frames": frames, "frames_per_second": 24.5, "divergences": [],
            "event_totals": {"divergences": 0},
            "live_particles": {"last": int(live[-1]), "max": int(live.max())},
            "live_per_frame": [int(n) for n in live], "flight": flight}


def test_plots_are_written_as_pngs_of_a_readable_size(tmp_path):
    paths = write_demo_plots(flight_report(), tmp_path)
    assert [p.name for p in paths] == ["live_and_emission_vs_time.png",
                                       "emission_vs_altitude.png"]
    for path in paths:
        assert path.parent == tmp_path / "plots"
        assert path.read_bytes()[:8] == PNG_SIGNATURE
        with Image.open(path) as image:
            image.verify()
        with Image.open(path) as image:
            width, height = image.size
            colours = image.convert("RGB").getcolors(maxcolors=1 << 20)
        assert width == 1000 and 400 <= height <= 800, (path.name, image.size)
        assert len(colours) > 50, f"{path.name} looks blank"


def test_no_flight_no_plots(tmp_path):
    report = flight_report()
    report["flight"] = []
    assert write_demo_plots(report, tmp_path) == []
    assert demo_summary(report) == []
    assert write_plots(report, tmp_path, Console(quiet=True)) == []
    assert not (tmp_path / "plots").exists()


def test_an_interrupted_run_with_one_flight_entry_more_still_plots(tmp_path):
    report = flight_report()
    report["flight"] = report["flight"][:31]
    report["live_per_frame"] = report["live_per_frame"][:30]
    assert len(write_demo_plots(report, tmp_path)) == 2


@pytest.mark.parametrize("flight_stride, live_stride", [(2, 1), (1, 4), (4, 2)])
def test_a_long_run_pairs_live_counts_and_flight_entries_of_the_same_frames(
        flight_stride, live_stride):
    """Past 4,096 frames the record keeps every n-th frame of each (n: the stride)."""
    report = flight_report()
    live = report["live_per_frame"]
    report["flight"] = report["flight"][flight_stride - 1::flight_stride]
    report["live_per_frame"] = live[live_stride - 1::live_stride]
    report["flight_frames_stride"], report["live_frames_stride"] = flight_stride, live_stride
    stride = max(flight_stride, live_stride)
    kept = range(stride, 121, stride)  # frames both kept
    peak = max(kept, key=lambda frame: live[frame - 1])
    rows = dict(demo_summary(report))
    assert rows["peak live particles"] == f"{live[peak - 1]:,} at t = {peak * 0.1:.2f} s"


def test_summary_names_the_peaks_and_where_they_came():
    rows = dict(demo_summary(flight_report()))
    assert rows["peak live particles"] == "150,000 at t = 9.10 s"
    assert rows["peak emission rate"] == "7,000 particles/s at 0.00 m altitude (t = 7.10 s)"
    assert rows["lowest altitude"] == "0.00 m at t = 6.10 s"
    start = 6000.0 * np.exp(-20.0 / 5.0)
    assert rows["emission rate: lowest altitude / start"] == \
        f"6,000 / {start:,.0f} particles/s"
    assert (rows["frames"], rows["frames per second"], rows["divergences"]) == \
        ("120", "24.5", "0")


@pytest.mark.parametrize("fps", [None, 12.0])
def test_summary_without_per_frame_counts_or_speed(fps):
    report = flight_report()
    del report["live_per_frame"]
    report["frames_per_second"] = fps
    rows = dict(demo_summary(report))
    assert rows["peak live particles"] == "150,000"
    assert rows["frames per second"] == ("-" if fps is None else "12.0")


def test_the_closing_table_holds_every_row():
    table = demo_table(flight_report())
    assert table.title == "brownout demo"
    assert table.row_count == len(demo_summary(flight_report())) == 7


@pytest.mark.parametrize("altitude, story", [
    ([10.0, 6.0, 2.0, 0.0, 0.0, 3.0, 8.0], "descends, lands and lifts off"),
    ([5.0, 5.2, 4.9, 5.1], "hovers"),
    ([8.0, 6.0, 4.0], "descends"),
    ([3.5, 2.0, 5.0], "descends and climbs"),
    ([0.0, 0.0, 4.0], "lands and lifts off"),
])
def test_the_plots_title_tells_the_flight_it_shows(altitude, story):
    assert flight_story(np.array(altitude)) == story


def purple_pixels(path) -> int:
    """Pixels of the plot in the colour of the dropped-particles line (tab:purple)."""
    with Image.open(path) as image:
        rgb = np.asarray(image.convert("RGB")).astype(int)
    return int((np.abs(rgb - (148, 103, 189)).sum(axis=2) < 30).sum())


def test_the_time_plot_carries_the_particles_dropped_at_capacity(tmp_path):
    """Summed over 4 frames a bin (a long run's): a line in its own colour on the emission's
    axis, drawn where the report counts drops; a report from before they were counted
    plots without it."""
    report = flight_report()
    sums = [0] * 15 + [1000] * 8 + [0] * 6 + [250]  # 30 bins of 4 frames: 117 frames
    report["frames"], report["capacity"] = 117, 150_000
    report["counters"] = {"values_from": "agreed", "frame_seconds": 0.1, "capacity_drops": {
        "id": 2, "label": "dropped at capacity", "unit": "particles", "events": True,
        "total": 8250, "first_frame": 61, "per_frame": sums, "per_frame_stride": 4,
        "frames_not_counted": 0, "frames_unagreed": 0}}
    drops = _drops(report)
    assert drops["capacity"] == 150_000
    np.testing.assert_allclose(drops["dropped_t"][-2:], [11.6, 11.7])
    # particles per second of the frames each bin holds: the last holds one
    np.testing.assert_allclose(drops["dropped"], [0.0] * 15 + [2500.0] * 8 + [0.0] * 6
                               + [2500.0])
    path, _ = write_demo_plots(report, tmp_path / "drops")
    assert purple_pixels(path) > 200
    del report["counters"]
    path, _ = write_demo_plots(report, tmp_path / "older")
    assert purple_pixels(path) == 0
