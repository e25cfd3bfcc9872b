"""The master's rules as pure functions, and the master's whole loop in this process over
walls simulated in memory (tests/support/memory_walls.py): no Zenoh, no GL, no child process."""

import logging
import threading
import time
from pathlib import Path

import numpy as np
import pytest
from memory_walls import MemoryLink

from cavesim.core.errors import ClusterError
from cavesim.core.frame_cost import NO_COST, PHASES
from cavesim.core.wire import (
    Command,
    ControlMessage,
    DisplayMessage,
    FrameMessage,
    HeadState,
    ReportMessage,
    SessionControls,
    TrackingMessage,
    WandState,
)
from cavesim.core.wire.credentials import OPERATOR, Identity
from cavesim.core.wire.payloads.from_nodes import Phase, Status
from cavesim.core.wire.payloads.poses import MAX_TRACKING_AGE
from nodes import lockstep
from nodes.lockstep import Membership
from nodes.master.events import ProcessEnded
from nodes.master.process import Master, MasterConfig, run_master
from nodes.master.resyncs import MAX_RESYNC_FAILURES
from nodes.master.swaps import WINDOW, SwapBook
from nodes.master.user_requests import Asked, Controller, UserRequests
from nodes.wall.frame_timer import FrameTimer

MINIMAL = Path(__file__).parents[2] / "config" / "scenes" / "minimal.toml"
BROWNOUT = MINIMAL.with_name("brownout.toml")  # a helicopter's: the scene has a state
WALLS = ("front", "left", "right")


def report(wall, digest, frame=1, particles=10, status=Status.STEPPED):
    return ReportMessage(frame, wall, digest * 32, particles, 0, NO_COST, status=status)


# -- membership ---------------------------------------------------------------------------

def test_walls_come_up_and_start_as_members_in_wall_order():
    m = Membership(WALLS)
    for wall in ("right", "front", "stranger", "left"):
        assert not m.all_up()
        m = m.came_up(wall)
    assert m.all_up() and m.alive == set(WALLS)
    assert m.started().members == WALLS


@pytest.mark.parametrize(("policy", "members"), [("continue", ("front", "right")),
                                                  ("pause", WALLS)])
def test_a_lost_member_leaves_or_holds_the_barrier_by_policy(policy, members):
    m = Membership(WALLS).came_up("front").came_up("left").came_up("right").started()
    m, lost = m.went_down("left", policy)
    assert lost and m.members == members and m.lost == {"left"} and "left" not in m.alive
    again, lost_again = m.went_down("left", policy)
    assert not lost_again or policy == "pause"


def test_a_wall_back_after_a_loss_joins_in_wall_order():
    m = Membership(WALLS, members=("front", "right"), alive=frozenset(WALLS) - {"left"},
                   lost=frozenset({"left"}))
    assert m.joiners() == ()  # up is not enough: its node must join this run
    m = m.came_up("left")
    assert m.joiners() == ("left",)
    m = m.admitted("left")
    assert m.members == WALLS and not m.lost and not m.joiners()


# -- the barrier, the vote, resyncs ------------------------------------------------------------

def test_missing_members_are_those_without_a_report():
    assert lockstep.missing(WALLS, {"front": report("front", "a")}) == ["left", "right"]


def test_after_a_stall_only_a_lost_member_that_is_back_is_resynced():
    m = Membership(WALLS, members=WALLS, alive=frozenset({"front", "left"}),
                   lost=frozenset({"left", "right"}))
    reported = {"front": report("front", "a")}
    assert lockstep.stall_resyncs(m, reported) == [("left", "front")]
    assert lockstep.stall_resyncs(m, {}) == []  # nobody healthy to copy from


def test_a_majority_names_the_odd_member():
    vote = lockstep.vote(WALLS, {"front": report("front", "a"), "left": report("left", "b"),
                                 "right": report("right", "a", particles=12)})
    assert (vote.agreed, vote.odd, vote.named, vote.source) == ("a" * 32, ("left",),
                                                                ("left",), "front")
    assert vote.diverged and vote.particles == 10


def test_without_a_majority_every_member_is_named_and_the_first_state_kept():
    two = ("front", "left")
    vote = lockstep.vote(two, {"front": report("front", "a"), "left": report("left", "b")})
    assert vote.agreed == "a" * 32 and vote.odd == ("left",) and vote.named == two


def test_agreement_and_frames_between_checks_name_nobody():
    same = {w: report(w, "a") for w in WALLS}
    assert not lockstep.vote(WALLS, same).diverged
    differ = {**same, "left": report("left", "b")}
    assert not lockstep.vote(WALLS, differ, compare=False).diverged


def test_a_resync_heals_only_with_the_sources_checksum():
    named = "a" * 32  # the digest the master named in its RESYNC
    assert lockstep.resync_outcome(None, named) is None
    assert lockstep.resync_outcome(report("left", "a"), named) is None  # a stepped report
    assert lockstep.resync_outcome(report("left", "a", status=Status.RESYNCED), named)
    assert not lockstep.resync_outcome(report("left", "b", status=Status.RESYNCED), named)


# -- the master's loop in this process ------------------------------------------------------

def run(link, frames=30, before_frame=None, **options):
    config = MasterConfig(tuple(link.walls), MINIMAL, frames, "memory",
                          barrier_timeout=options.pop("barrier_timeout", 0.05), **options)
    return run_master(config, link, before_frame=before_frame)


def test_a_healthy_run_agrees_on_every_frame_and_stops_the_walls():
    link = MemoryLink(WALLS)
    # walls in memory answer at once: a barrier of 1 s stalls only if something is wrong,
    # where 50 ms also stalled when a loaded machine held the master's thread back
    record = run(link, barrier_timeout=1.0)
    assert record.frames == 30 and not record.divergences and not record.stalls
    assert record.final.agree and record.final.all_walls_in
    assert set(record.gpus) == set(WALLS)
    assert isinstance(link.sent[-1], ControlMessage) and link.sent[-1].command is Command.STOP


def test_a_flipped_state_is_named_by_majority_and_resynced():
    link = MemoryLink(WALLS)
    link.walls["left"].flip_at.add(12)
    record = run(link)
    (divergence,) = record.divergences
    assert (divergence.frame, divergence.nodes) == (12, ("left",))
    (resync,) = record.resyncs
    assert (resync.node, resync.source, resync.ok) == ("left", "front", True)
    assert record.final.agree


def test_a_dropped_frame_stalls_the_barrier_and_is_sent_again():
    link = MemoryLink(WALLS)
    link.walls["right"].drop_once.add(7)
    record = run(link)
    (stall,) = record.stalls
    assert stall.frame == 7 and stall.nodes == {"right": (7, 6)}
    assert not record.divergences and record.final.agree


def test_a_lost_wall_is_dropped_then_rejoins_by_resync():
    link = MemoryLink(WALLS)

    def fault(k):
        if k == 10:
            link.go_down("left")
        elif k == 20:
            link.come_up("left")

    record = run(link, before_frame=fault)
    (loss,) = record.losses
    assert (loss.node, loss.frame) == ("left", 10)  # the frame in flight when it went
    (join,) = record.joins
    # up at 20; info asked and WELCOME sent at 20-21, JOINED then admitted by resync
    assert join.node == "left" and 20 <= join.frame <= 22
    assert record.final.agree and record.final.all_walls_in


@pytest.mark.parametrize("policy", ["continue", "pause"])
def test_a_member_silent_past_the_limit_is_evicted_or_ends_the_run_by_policy(policy):
    link = MemoryLink(WALLS)
    link.walls["left"].silent_from = 5  # up (its liveliness stays) but never reports again
    if policy == "pause":
        with pytest.raises(ClusterError, match=r"frame 5: left silent for \d+ s under "
                                               r"--on-loss pause \(--max-pause 0.3 s\)"):
            run(link, on_loss="pause", max_pause=0.3)
        return
    record = run(link, on_loss="continue", evict_after=0.3)
    (loss,) = record.losses
    assert (loss.frame, loss.node, loss.detected_by) == (5, "left", "barrier")
    assert record.frames == 30 and record.final.lost == ("left",)
    assert record.summary()["final"]["lost"] == ["left"]


def test_a_node_whose_resyncs_keep_failing_is_given_up_after_a_bounded_number():
    link = MemoryLink(WALLS)
    link.walls["left"].flip_at.add(8)
    link.resync_fails.add("left")
    record = run(link)
    tries = [r for r in record.resyncs if r.node == "left"]
    assert len(tries) == MAX_RESYNC_FAILURES and not any(r.ok for r in tries)
    (loss,) = record.losses
    assert (loss.node, loss.detected_by) == ("left", "resync-failed")
    assert record.frames == 30 and record.final.lost == ("left",) and record.final.agree


def test_a_colliding_state_from_the_source_is_refused_and_the_next_holder_heals_the_node():
    """The source is an insider serving a state built to match the named checksum: the
    second holder, named to confirm it, refuses it; the same frame, the next holder is the
    source, confirmed by the first, and the node heals (nothing colliding is committed)."""
    link = MemoryLink(WALLS)
    link.walls["left"].flip_at.add(8)
    link.colliding.add("front")
    record = run(link)
    tries = [(r.frame, r.node, r.source, r.confirmer, r.ok) for r in record.resyncs]
    assert tries == [(8, "left", "front", "right", False), (8, "left", "right", "front", True)]
    assert [r.to_json()["confirmation"] for r in record.resyncs] == [None, "confirmed by front"]
    assert [d.frame for d in record.divergences] == [8] and record.final.agree
    resyncs = [m for m in link.sent if isinstance(m, ControlMessage)
               and m.command is Command.RESYNC]
    assert [(m.source, m.confirmer) for m in resyncs] == [("front", "right"), ("right", "front")]


def test_a_resync_with_no_second_wall_says_it_is_unconfirmed():
    link = MemoryLink(("front", "left"))
    link.walls["left"].flip_at.add(8)
    record = run(link)
    (resync,) = record.resyncs
    assert (resync.source, resync.confirmer, resync.ok) == ("front", None, True)
    assert resync.to_json()["confirmation"] == "unconfirmed: no second wall"


def test_resync_roles_take_each_holder_in_turn_confirmed_by_the_next():
    assert lockstep.resync_roles(("front", "right", "floor")) == (
        ("front", "right"), ("right", "floor"), ("floor", "front"))
    assert lockstep.resync_roles(("front",)) == (("front", None),)
    walls = ("front", "left", "right", "floor")
    reports = {w: report(w, d) for w, d in zip(walls, "aaba", strict=True)}
    assert lockstep.holders(walls, reports, "a" * 32, "left", "floor", odd=("front",)) \
        == ("floor",)
    assert lockstep.holders(walls, reports, "a" * 32, "right", "front") \
        == ("front", "left", "floor")


def test_the_master_keeps_only_the_reports_of_the_frame_in_flight():
    link = MemoryLink(WALLS)
    config = MasterConfig(WALLS, MINIMAL, 50, "memory", barrier_timeout=0.05)
    master = Master(config, link)
    master.wait_for_walls()
    master.run()
    assert master.frame == 50 and set(master.reports) <= set(WALLS)
    assert all(r.frame == 50 for r in master.reports.values())


def test_ctrl_c_in_a_barrier_stops_the_walls_with_the_newest_frame_sent():
    class InterruptedLink(MemoryLink):
        def send(self, message):
            super().send(message)
            if isinstance(message, FrameMessage) and message.frame == 10:
                raise KeyboardInterrupt  # Ctrl-C just after frame 10 went out

    link = InterruptedLink(WALLS)
    record = run(link)
    assert record.interrupted and record.frames == 9
    stop = link.sent[-1]
    assert stop.command is Command.STOP and stop.frame == 10  # not older than frame 10


def test_when_every_wall_goes_at_once_a_failed_process_says_why():
    link = MemoryLink(WALLS)

    def all_fail(k):
        if k == 5:
            for wall in WALLS:
                link.go_down(wall)  # liveliness goes first; the process watcher is slower
            threading.Timer(0.2, link.events.put, (ProcessEnded(
                "left", 1, "wall left exited with code 1: cannot write out/x.png: No space "
                "left on device"),)).start()

    with pytest.raises(ClusterError, match="wall left exited with code 1: cannot write"):
        run(link, before_frame=all_fail)


def test_a_late_wall_times_the_join_out_with_a_clear_error():
    with pytest.raises(ClusterError, match=r"walls \['right'\] did not join within 0.2 s "
                                           r"\(--join-timeout\)"):
        run(MemoryLink(WALLS, late=("right",)), join_timeout=0.2)


def test_an_unknown_loss_policy_is_refused():
    with pytest.raises(ValueError, match="on_loss must be one of"):
        run(MemoryLink(WALLS), on_loss="panic")


# -- the swap barrier ---------------------------------------------------------------------------

def test_displaying_walls_swap_each_frame_only_after_all_have_drawn_it():
    link = MemoryLink(WALLS, displaying=("front", "left"))
    record = run(link)
    swap = record.summary()["swap"]
    assert swap["walls"] == ["front", "left"] and swap["frames"] == 30
    assert swap["order_violations"] == 0 and swap["stalls"] == [] and swap["incomplete"] == 0
    assert [k for k, _ in link.walls["front"].swaps] == list(range(1, 31))
    assert not link.walls["right"].swaps  # headless: never in the swap barrier
    assert swap["skew_ms"]["p99"] >= 0


def test_a_wall_that_never_says_drawn_stalls_the_swap_which_is_released_anyway():
    link = MemoryLink(WALLS, displaying=("front", "left"))
    link.walls["left"].draws_late.add(12)
    record = run(link)
    swap = record.summary()["swap"]
    assert swap["stalls"] == [12] and record.frames == 30
    assert swap["order_violations"] == 1  # frame 12 swapped without left's DRAWN
    assert len(link.walls["front"].swaps) == 30


def test_the_next_frame_goes_out_only_after_every_wall_swapped_the_last():
    link = MemoryLink(WALLS, displaying=("front", "left"))
    link.walls["left"].swap_seconds = 0.01  # a slow swap: the frame lock waits for it
    run(link, frames=10, barrier_timeout=1.0)
    time.sleep(0.1)  # any swap still under way comes in
    assert [k for k, _ in link.walls["left"].swaps] == list(range(1, 11))
    frames_sent = {m.frame: t for m, t in zip(link.sent, link.sent_ns, strict=True)
                   if not isinstance(m, ControlMessage)}
    for k, swapped in link.walls["left"].swaps[:-1]:
        assert frames_sent[k + 1] > swapped, f"frame {k + 1} went out before left swapped {k}"


def test_a_swap_that_never_returns_is_given_up_and_the_run_goes_on():
    link = MemoryLink(WALLS, displaying=("front", "left"))
    link.walls["left"].swap_hangs.add(7)
    record = run(link)
    swap = record.summary()["swap"]
    assert record.frames == 30 and swap["incomplete"] == 1 and swap["frames"] == 29


def test_the_swap_book_finds_a_swap_before_the_last_drawing():
    book = SwapBook()
    for node, phase, t in (("a", Phase.DRAWN, 100), ("a", Phase.SWAPPED, 150),
                           ("b", Phase.DRAWN, 200), ("b", Phase.SWAPPED, 210)):
        book.note(DisplayMessage(1, node, phase, t))
    book.released(1, ("a", "b"), stalled=False)
    assert book.order_violations == 1 and book.settled(1)
    assert (book.skews.count, book.skews.max) == (1, 60e-9)
    book.released(2, ("a", "b"), stalled=False)
    assert not book.settled(2)
    book.give_up(2)
    assert book.incomplete == 1 and book.settled(2)


def test_the_swap_book_forgets_late_messages_of_old_frames():
    book = SwapBook()
    book.note(DisplayMessage(3, "a", Phase.SWAPPED, 1))  # for a frame it never waits on
    book.released(3 + WINDOW + 1, ("a",), stalled=False)
    assert not book._swapped.get(3)


# -- tracking -------------------------------------------------------------------------------

def test_tracking_that_went_quiet_holds_the_head_and_releases_the_wand(caplog):
    """A tracker that stops leaves no button pressed: once its last message is older than
    MAX_TRACKING_AGE, frames keep its head but carry an idle wand; a fresh one is used as
    it is."""
    caplog.set_level(logging.INFO, "cavesim.master")
    link = MemoryLink(WALLS)
    master = Master(MasterConfig(WALLS, MINIMAL, 3), link)
    pressed = WandState((0.25, 0.5, 1.0), buttons=1, axes=(1.0, 0.0, 0.0, 0.0))
    head = HeadState((0.5, -0.5, 1.625))
    link.tracking = TrackingMessage(0, head, pressed, time.time_ns())
    fresh = master.inputs.make(1, Asked())
    assert fresh.head == head and fresh.wand.buttons == 1
    link.tracking = TrackingMessage(0, head, pressed,
                                    time.time_ns() - int((MAX_TRACKING_AGE + 1) * 1e9))
    quiet = master.inputs.make(2, Asked())
    assert quiet.head == head and quiet.wand == WandState()
    assert "tracking went quiet" in caplog.text
    link.tracking = TrackingMessage(0, head, pressed, time.time_ns())
    assert master.inputs.make(3, Asked()).wand.buttons == 1 and "tracking is back" in caplog.text


def test_a_pause_holds_simulation_time_and_a_reset_starts_the_scene_over_frame_by_frame():
    """Paused frames carry dt 0 and the last frame's scene state (the head still moves); a
    reset frame tells the nodes to start over and carries the scene's first step again,
    also in a pause, which then holds it; frame numbers go on."""
    link, head = MemoryLink(WALLS), HeadState((0.5, -0.5, 1.625))
    master = Master(MasterConfig(WALLS, BROWNOUT, 9), link)
    fresh = Master(MasterConfig(WALLS, BROWNOUT, 9), MemoryLink(WALLS))
    first, second = (fresh.inputs.make(k, Asked()) for k in (1, 2))
    frames = [master.inputs.make(1, Asked(paused=True)),  # nothing to hold yet: it steps
              master.inputs.make(2, Asked())]
    link.tracking = TrackingMessage(0, head, WandState((1.0, 1.0, 1.0)), time.time_ns())
    frames.append(master.inputs.make(3, Asked(paused=True)))
    link.tracking = None
    frames += [master.inputs.make(4, Asked(paused=True, reset=True)),
              master.inputs.make(5, Asked(paused=True)), master.inputs.make(6, Asked())]
    assert [f.inputs.dt for f in frames] == [np.float32(1 / 60)] * 2 + [0.0] \
        + [np.float32(1 / 60), 0.0, np.float32(1 / 60)]
    assert [f.reset for f in frames] == [False, False, False, True, False, False]
    assert frames[0].params == first.params and frames[1].params == second.params
    assert frames[2].params == second.params and frames[2].wand == second.wand  # held
    assert frames[3].params == frames[4].params == first.params  # the scene's first again
    assert frames[5].params == second.params
    assert frames[2].head == head  # the head is the user's still
    assert [(a.frame, a.action) for a in master.record.user_actions] == [
        (3, "pause"), (4, "reset"), (6, "resume")]
    assert master.record.paused_frames == 2
    assert len(master.record.flight) == 6  # one per frame made: a paused one holds its state


def test_the_previews_quit_ends_the_run_cleanly_between_two_frames():
    """The user's quit is taken before the next frame: every wall has agreed on the last
    one, all are told to stop, and the record says the user ended the run, and who asked."""
    link = MemoryLink(WALLS)

    def quit_at_5(k):
        if k == 5:
            link.controller = Controller(TrackingMessage(
                0, HeadState(), WandState(), time.time_ns(), False, SessionControls(quit=True)),
                Identity(OPERATOR, "preview"))

    record = run_master(MasterConfig(WALLS, MINIMAL, 20, "memory"), link, before_frame=quit_at_5)
    assert record.user_stopped and not record.interrupted and record.frames == 4
    assert record.final.agree and record.final.all_walls_in and not record.losses
    assert any(isinstance(m, ControlMessage) and m.command is Command.STOP for m in link.sent)
    assert record.summary()["user_stopped"]
    assert record.summary()["user_actions"] == [
        {"frame": 5, "action": "stop", "by": "operator preview"}]


def test_user_requests_read_levels_and_count_resets():
    """Pause and quit are levels; a reset is one more than last seen (a new sender's lower
    count is adopted, not a reset); controls gone quiet ask nothing."""
    requests, now = UserRequests(), time.time_ns()

    def sent(controls, age=0.0):
        return Controller(TrackingMessage(0, HeadState(), WandState(), now - int(age * 1e9),
                                          False, controls))

    assert requests.take(None) == Asked()
    assert requests.take(sent(SessionControls(paused=True)), now) == Asked(paused=True)
    assert requests.take(sent(SessionControls(True, 1)), now) == Asked(True, True)
    assert requests.take(sent(SessionControls(False, 1)), now) == Asked()
    assert requests.take(sent(SessionControls(resets=3)), now) == Asked(reset=True)
    assert requests.take(sent(SessionControls(resets=0)), now) == Asked()  # a new preview
    assert requests.take(sent(SessionControls(resets=1)), now) == Asked(reset=True)
    assert requests.take(sent(SessionControls(True, 2, True), MAX_TRACKING_AGE + 1),
                         now) == Asked()
    assert requests.take(sent(SessionControls(quit=True)), now) == Asked(quit=True)
    signed = Controller(sent(SessionControls(paused=True)).message, Identity(OPERATOR, "desk"))
    assert requests.take(signed, now) == Asked(paused=True, by="operator desk")


# -- where a frame goes -------------------------------------------------------------------------

def test_the_walls_frame_costs_reach_the_report_by_wall_and_phase():
    """Each stepped report's phase times go into the record's histograms; report.json gives
    their percentiles per wall (a join or a resync times nothing and is not counted)."""
    link = MemoryLink(WALLS)
    record = run_master(MasterConfig(WALLS, MINIMAL, 20, "memory"), link)
    cost = record.summary()["frame_cost_ms"]
    assert set(cost) == set(WALLS)
    for wall in WALLS:
        assert list(cost[wall]) == list(PHASES)
        for i, phase in enumerate(PHASES):
            assert cost[wall][phase]["p50"] == pytest.approx(i + 1, rel=1e-3)
    assert record.frame_cost.count(WALLS[0]) == 20  # stepped frames only, not the join


class FakeFence:
    """Waited `waits` seconds (in turn) before each lap."""

    def __init__(self, *waits: float) -> None:
        self.waits = list(waits)

    def take_waited(self) -> float:
        return self.waits.pop(0) if self.waits else 0.0


class FakeTimers:
    def read_us(self) -> dict[str, int]:
        return {"emitter_pass": 100, "particle_pass": 2_000, "checksum_pass": 300}


def test_a_nodes_timer_laps_its_phases_and_carries_the_report_and_drawing_over(monkeypatch):
    clock = iter([0.0, 10.0, 10.5, 12.0, 13.0, 13.25, 14.0, 16.0, 30.0, 30.5]).__next__
    monkeypatch.setattr(time, "perf_counter", clock)
    # arriving, then decode, step (0.5 s of it on the GPU's fence), checksum (0.25 s)
    timer = FrameTimer(FakeFence(0.0, 0.0, 0.5, 0.25), FakeTimers())  # 0.0
    timer.arrived()  # 10.0: no report before it, no wait
    for phase in ("decode", "step", "checksum"):  # 10.5, 12.0, 13.0
        timer.lap(phase)
    timer.gpu_passes()
    timer.lap("history")  # 13.25
    first = dict(zip(PHASES, timer.cost_us(), strict=True))
    assert first == {"input_wait": 0, "decode": 500_000, "step": 1_000_000,
                     "emitter_pass": 100, "particle_pass": 2_000, "checksum_pass": 300,
                     "gpu_sync": 750_000, "checksum": 750_000, "history": 250_000,
                     "report": 0, "render": 0}
    timer.reported()  # 14.0
    timer.rendered()  # 16.0
    timer.arrived()  # 30.0: 14 s after the wall was drawn, the node ready again
    timer.lap("decode")  # 30.5
    second = dict(zip(PHASES, timer.cost_us(), strict=True))
    assert (second["input_wait"], second["decode"], second["gpu_sync"]) == (14_000_000,
                                                                           500_000, 0)
    assert (second["report"], second["render"]) == (750_000, 2_000_000)  # of the frame before
