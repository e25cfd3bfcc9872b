"""The master's book of the run's counters (nodes/master/counter_book.py): each row of the
table kept as it says from the agreed counts, its notice said once (the master's log and
`cavesim run`'s terminal), report.json's `counters` section and the run table's rows, all
generated from the table."""

import logging

from rich.console import Console
from scenes import FOUNTAIN, SMOKE, scene_dict

from cavesim.core.counters import BY_NAME
from cavesim.core.scene import load_scene, parse_scene
from cavesim.tools.reports.run_tables import counter_rows, summary_table
from nodes.commands.run import counter_notices
from nodes.master.counter_book import AUTHORITY, CounterBook
from nodes.master.run_record import RunRecord

DT = 1 / 60
BROWNOUT = "config/scenes/brownout.toml"
EXITS, DROPS = BY_NAME["domain_exits"].id, BY_NAME["capacity_drops"].id
TRACERS, TAKEN = BY_NAME["tracers_stepped"].id, BY_NAME["substeps_taken"].id
RETAKEN, MOST = BY_NAME["substeps_retaken"].id, BY_NAME["most_substeps"].id
DROP_LINE = ("capacity full: 1,234 new particles dropped at frame 3 (the scene holds 300); "
             "report.json counts every frame's (counters.capacity_drops)")


def smoky(tracer_method: str | None = "rk45"):
    data = scene_dict(integrator="rk4", emitters=[FOUNTAIN], capacity=300)
    data["particle_class"] = [*data["particle_class"], dict(SMOKE)]
    if tracer_method is not None:
        data["simulation"]["tracer_method"] = tracer_method
    return parse_scene(data, name="smoky")


def test_a_per_class_row_keeps_totals_first_frames_and_every_frame_and_warns_once(caplog):
    book = CounterBook(smoky(None), DT)
    with caplog.at_level(logging.WARNING, logger="cavesim.master"):
        for k, exits in enumerate([(0, 0, 0), (0, 3, 0), (2, 1, 0), (0, 0, 0)], start=1):
            book.add(k, {EXITS: exits, DROPS: (0,)})
    [warning] = caplog.messages
    assert warning.startswith("frame 2: particles left the field's box [-4.0, -4.0, 0.0] .. "
                              "[4.0, 4.0, 4.0] (3 dust); beyond it the flow is the nearest "
                              "boundary node's (out_of_domain)")
    assert book.notices == [warning]
    exits = book.summary()["domain_exits"]
    assert exits == {"id": 1, "label": "left the field's box", "unit": "particles",
                     "events": True, "classes": ["sand", "dust", "smoke"],
                     "total": {"sand": 2, "dust": 4, "smoke": 0},
                     "first_frame": {"sand": 3, "dust": 2, "smoke": None},
                     "per_frame": [{"sand": 0, "dust": 0, "smoke": 0},
                                   {"sand": 0, "dust": 3, "smoke": 0},
                                   {"sand": 2, "dust": 1, "smoke": 0},
                                   {"sand": 0, "dust": 0, "smoke": 0}],
                     "per_frame_stride": 1, "frames_not_counted": 0, "frames_unagreed": 0}
    assert counter_rows(book.summary())[0] == ("left the field's box",
                                               "2 sand from frame 3, 4 dust from frame 2")


def test_a_single_row_says_its_notice_once_and_keeps_no_zeros_until_it_counts(caplog):
    book = CounterBook(load_scene(BROWNOUT), DT)
    assert set(book.rows) == {DROPS, BY_NAME["ground_deposits"].id}, (
        "a rotor's flow has no box, its scene no tracers")
    book.add(1, {DROPS: (0,), BY_NAME["ground_deposits"].id: (0, 0)})
    quiet = book.summary()["capacity_drops"]
    assert quiet["total"] == 0 and quiet["first_frame"] is None and quiet["per_frame"] == []
    assert counter_rows(book.summary()) == [("dropped at capacity", "none"),
                                            ("on the ground", "none")]
    scene = parse_scene(scene_dict(emitters=[FOUNTAIN], capacity=300, drag=False), name="full")
    book = CounterBook(scene, DT)
    with caplog.at_level(logging.WARNING, logger="cavesim.master"):
        for k, dropped in enumerate([0, 0, 1234, 50, 0], start=1):
            book.add(k, {DROPS: (dropped,)})
    assert caplog.messages == book.notices == [DROP_LINE]
    drops = book.summary()["capacity_drops"]
    assert (drops["total"], drops["first_frame"]) == (1284, 3)
    assert drops["per_frame"] == [0, 0, 1234, 50, 0] and drops["per_frame_stride"] == 1
    assert counter_rows(book.summary()) == [("dropped at capacity",
                                             "1,284 particles from frame 3")]


def test_a_level_keeps_its_largest_and_when_and_frames_without_counts_are_said():
    book = CounterBook(smoky(), DT)
    frames = [{TRACERS: (10,), TAKEN: (10,), RETAKEN: (0,)},  # its most: no majority
              {TRACERS: (10,), TAKEN: (17,), RETAKEN: (4,), MOST: (3,)},
              {},  # no member counted: a GS/TF context without vertex storage
              {TRACERS: (12,), TAKEN: (30,), RETAKEN: (9,), MOST: (5,)}]
    for k, counts in enumerate(frames, start=1):
        book.add(k, {EXITS: (0, 0, 0), DROPS: (0,), **counts},
                 unagreed=(MOST,) if k == 1 else ())
    summary = book.summary()
    most = summary["most_substeps"]
    assert (most["largest"], most["largest_frame"]) == (5, 4)
    assert "total" not in most and "per_frame" not in most, "a level has no total"
    assert (most["frames_not_counted"], most["frames_unagreed"]) == (1, 1)
    taken = summary["substeps_taken"]
    assert taken["total"] == 57 and taken["per_frame"] == [10, 17, 0, 30]
    assert "first_frame" not in taken and taken["frames_not_counted"] == 1
    assert dict(counter_rows(summary)) == {
        "left the field's box": "none", "dropped at capacity": "none",
        "tracers stepped": "32 tracers (1 frames not counted)",
        "tracer substeps taken": "57 substeps (1 frames not counted)",
        "tracer substeps retaken": "13 substeps from frame 2 (1 frames not counted)",
        "most substeps of one tracer": "at most 5 substeps (frame 4) (1 frames not counted, "
                                       "1 frames without agreement)"}


def test_report_json_has_one_counters_section_with_the_skipped_ids_per_wall():
    book = CounterBook(smoky(None), DT, AUTHORITY)
    book.add(1, {EXITS: (0, 1, 0), DROPS: (0,)})
    book.skip({"left": 2})
    book.skip({"left": 1, "front": 1})
    record = RunRecord(("front", "left"), capacity=300, counters=book)
    report = record.summary()
    assert report["capacity"] == 300
    section = report["counters"]
    assert set(section) == {"values_from", "frame_seconds", "unknown_ids_skipped",
                            "domain_exits", "capacity_drops"}
    assert section["values_from"] == "authority" and section["frame_seconds"] == round(DT, 9)
    assert section["unknown_ids_skipped"] == {"front": 1, "left": 3}
    assert counter_rows(section)[-1] == ("counters from", "the authority (mixed hardware)")
    assert RunRecord(("front",)).summary()["counters"] == {}


def test_the_run_table_has_one_row_per_counter_and_the_terminal_each_notice_once():
    console = Console(record=True, width=200)
    tell = counter_notices(console)
    record = RunRecord(("front",), counters=CounterBook(
        parse_scene(scene_dict(emitters=[FOUNTAIN], capacity=300), name="full"), DT))
    for k, dropped in enumerate([0, 0, 1234, 50, 7], start=1):
        record.counters.add(k, {EXITS: (0, 2 * (k == 5)), DROPS: (dropped,)})
        record.frame_done(k, 0.001, 300)
        tell(record)
    lines = console.export_text().splitlines()
    assert lines[0] == DROP_LINE and lines[1].startswith("frame 5: particles left the field's")
    assert len(lines) == 2
    table = Console(record=True, width=200)
    table.print(summary_table({**record.summary(), "frames_per_second": 60.0}))
    text = table.export_text()
    assert "dropped at capacity" in text and "1,291 particles from frame 3" in text
    assert "left the field's box" in text and "2 dust from frame 5" in text
