"""The DTrack bridge: the head and wand kept between datagrams (cavesim.core.tracking.state),
published per datagram or at a capped rate with bad datagrams counted and their warnings
rate-limited (nodes.tracker.bridge), and `cavesim tracker` end to end: recorded datagrams
sent from a loopback socket come out as signed TrackingMessages on the session's key."""

from __future__ import annotations

import json
import logging
import os
import queue
import signal
import socket
import subprocess
import sys
import time

import pytest
import zenoh
from dtrack_packets import FLYSTICK_HIDDEN, HEAD_LOST, NOTHING, TRACKED, datagram

from cavesim.core.errors import TrackerError
from cavesim.core.tracking import Target, Tracked, TrackerMapping, TrackingState, parse_datagram
from cavesim.core.tracking.dtrack import MAX_DATAGRAM
from cavesim.core.wire import HeadState, SessionKeys, TrackingMessage, WandState, decode
from cavesim.core.wire.credentials import generate
from cavesim.core.wire.key_files import read_key_file, write_key_files
from cavesim.core.wire.network import NetworkSettings, zenoh_config
from nodes.launch.launcher import free_port
from nodes.tracker.bridge import Bridge, open_dtrack_socket

MAPPING = TrackerMapping(Target(Tracked.BODY, 0), Target(Tracked.FLYSTICK, 0))
HEAD_M = (0.12, -0.3505, 1.7123)  # dtrack_packets.HEAD_MM in metres
FLYSTICK_M = (0.3, 0.4, 1.1)
GARBAGE = b"\xffnot DTrack"


def state_after(*datagrams: bytes, mapping: TrackerMapping = MAPPING):
    state = TrackingState(mapping)
    missing = [state.update(parse_datagram(d)) for d in datagrams]
    return state, missing


# --- the state between datagrams ------------------------------------------------------

def test_a_lost_head_keeps_its_last_pose_and_is_counted():
    state, missing = state_after(TRACKED, HEAD_LOST)
    assert missing == [(), ("head",)]
    assert state.head.position == pytest.approx(HEAD_M)
    assert state.wand.position == pytest.approx((0.31, 0.4, 1.1)) and state.wand.buttons == 1
    assert state.wand.axes == (0.0, 0.5, 0.0, 0.0)


def test_a_hidden_flystick_keeps_its_pose_but_not_its_buttons():
    state, missing = state_after(TRACKED, FLYSTICK_HIDDEN)
    assert missing == [(), ("wand",)]
    assert state.wand.position == pytest.approx(FLYSTICK_M)
    assert (state.wand.buttons, state.wand.axes) == (16, (-0.5, 0.0, 0.0, 0.0))
    assert state.head.position == pytest.approx((0.1215, -0.349, 1.71))


def test_before_a_target_is_seen_it_has_the_default_pose():
    state, missing = state_after(NOTHING, HEAD_LOST)
    assert missing == [("head", "wand"), ("head",)]
    assert state.head == HeadState() and state.wand.buttons == 1
    message = state.message(9)  # stamped with its send time
    assert message == TrackingMessage(9, HeadState(), state.wand, message.sent_ns)
    assert abs(message.sent_ns - time.time_ns()) < 5e9


def test_a_wand_on_a_standard_body_has_no_buttons_and_an_absent_flystick_keeps_its_own():
    wand = TrackerMapping(wand=Target(Tracked.BODY, 3))
    state, missing = state_after(TRACKED, mapping=wand)
    assert state.wand.position == pytest.approx((-0.8124, 1.033, 0.0952))
    assert (state.wand.buttons, state.head, missing) == (0, HeadState(), [()])
    state, _ = state_after(TRACKED, datagram("fr 1", "6d 0"))
    assert (state.wand.buttons, state.wand.axes) == (5, (0.25, -1.0, 0.0, 0.0))


# --- the bridge: rate, rejects, warnings ------------------------------------------------

def test_every_datagram_is_published_and_garbage_only_counted():
    sent: list[TrackingMessage] = []
    bridge = Bridge(MAPPING, sent.append)
    for t, data in enumerate((TRACKED, GARBAGE, b"x" * (MAX_DATAGRAM + 1), HEAD_LOST)):
        bridge.receive(data, float(t))
    assert [m.frame for m in sent] == [21753, 21754]
    assert bridge.counts.summary() == {"datagrams": 4, "published": 2,
                                       "rejected": {"not-ascii": 1, "too-large": 1},
                                       "missing": {"head": 1}}
    bridge.receive(datagram("6d 0"), 5.0)  # no frame counter: the datagrams so far
    assert sent[-1].frame == 5


def test_a_capped_rate_holds_back_and_then_sends_the_newest_state():
    sent: list[TrackingMessage] = []
    bridge = Bridge(MAPPING, sent.append, max_rate=10.0)
    bridge.receive(TRACKED, 100.0)
    bridge.receive(HEAD_LOST, 100.02)
    bridge.receive(FLYSTICK_HIDDEN, 100.05)
    assert [m.frame for m in sent] == [21753]
    assert bridge.timeout(100.05) == pytest.approx(0.05)  # wakes when the held state is due
    bridge.flush(100.09)
    bridge.flush(100.1)
    assert [m.frame for m in sent] == [21753, 21755] and sent[-1].wand.buttons == 16
    bridge.flush(100.5)  # nothing new: nothing sent
    assert len(sent) == bridge.counts.published == 2 and bridge.counts.datagrams == 3


def test_bad_datagrams_warn_at_most_once_per_interval(caplog):
    bridge = Bridge(MAPPING, lambda m: None)
    with caplog.at_level(logging.WARNING, logger="cavesim.tracker"):
        for t in (0.0, 1.0, 2.0, 3.0, 10.5, 11.0):
            bridge.receive(GARBAGE, t)
    lines = [r.getMessage() for r in caplog.records]
    assert len(lines) == 2 and bridge.counts.rejected == {"not-ascii": 6}
    assert lines[0].startswith("rejected a DTrack datagram of 11 bytes: not-ascii: byte 0xff")
    assert lines[1].endswith("(3 more since the last warning)")


def test_a_port_in_use_is_named():
    with open_dtrack_socket("127.0.0.1", 0) as taken:
        port = taken.getsockname()[1]
        with pytest.raises(TrackerError, match=f"udp 127.0.0.1:{port}: Address already in use"):
            open_dtrack_socket("127.0.0.1", port)


# --- `cavesim tracker` --------------------------------------------------------------------

def cavesim(*args: str, **kwargs) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "cavesim", *args], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, **kwargs)


def test_bad_flags_and_files_are_one_line_usage_errors(tmp_path):
    bad = tmp_path / "map.toml"
    bad.write_text('[head]\nbody = 0\nflystick = 1\n')
    cases = [(("--dtrack", "5000", "--map", str(bad)),
              "cavesim tracker: error: argument --map: "),
             (("--dtrack", "5000", "--map", str(tmp_path / "none.toml")),
              "cavesim tracker: error: argument --map: no tracker mapping file"),
             (("--dtrack", "70000",), "cavesim tracker: error: argument --dtrack: expected a UDP"),
             (("--dtrack", "5000", "--session", "a/b"),
              "cavesim tracker: error: argument --session: session must be 1-32")]
    for args, start in cases:
        process = cavesim("tracker", *args)
        _, err = process.communicate(timeout=60)
        assert process.returncode == 2 and err.startswith(start), err
        assert len(err.strip().splitlines()) == 1, err


def test_a_taken_port_ends_the_tracker_with_one_line():
    with open_dtrack_socket("127.0.0.1", 0) as taken:
        port = taken.getsockname()[1]
        process = cavesim("tracker", "--dtrack", str(port), "--bind", "127.0.0.1")
        _, err = process.communicate(timeout=60)
    assert process.returncode == 1
    assert err.strip() == (f"cavesim: error: cannot receive DTrack datagrams on udp "
                           f"127.0.0.1:{port}: Address already in use; give a free --dtrack "
                           f"port and an address of this host (or 0.0.0.0) for --bind")


def free_udp_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


@pytest.mark.slow
def test_recorded_datagrams_reach_a_subscriber_as_signed_tracking_messages(tmp_path):
    session = f"dtrack{os.getpid()}"
    _, session_key = write_key_files(tmp_path, generate(), (), ("dtrack",))
    key = read_key_file(session_key, "tracker")  # the tracker's own, certified by the master
    endpoint, port = f"tcp/127.0.0.1:{free_port()}", free_udp_port()
    tracker = cavesim("tracker", "--dtrack", str(port), "--bind", "127.0.0.1", "--map",
                      "config/tracking/dtrack.toml", "--listen", endpoint, "--session", session,
                      "--key-file", str(session_key), "--report", str(tmp_path / "r.json"),
                      "--verbose", start_new_session=True,  # SIGINT at its default, as
                      # a terminal's Ctrl-C finds it, however this test runner was started
                      preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    received: queue.Queue[TrackingMessage] = queue.Queue()
    with zenoh.open(zenoh_config(NetworkSettings(connect=(endpoint,)))) as listener, \
            socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as dtrack:
        subscriber = listener.declare_subscriber(SessionKeys(session).tracking, lambda sample:
                                                 received.put(decode(sample.payload.to_bytes(),
                                                                     session, key)))
        deadline, sent = time.monotonic() + 60, 0
        while received.empty():  # until the tracker is up and the subscriber is heard
            assert tracker.poll() is None, tracker.communicate()[1]
            assert time.monotonic() < deadline, "no tracking message within 60 s"
            dtrack.sendto(TRACKED, ("127.0.0.1", port))
            sent += 1
            time.sleep(0.05)
        for data in (GARBAGE, b" " * (MAX_DATAGRAM + 1), HEAD_LOST, FLYSTICK_HIDDEN):
            dtrack.sendto(data, ("127.0.0.1", port))
        messages = {}
        while 21755 not in messages:
            message = received.get(timeout=30)
            messages[message.frame] = message
        subscriber.undeclare()
    tracker.send_signal(signal.SIGINT)
    out, err = tracker.communicate(timeout=30)
    assert tracker.returncode == 0, err
    head_lost, hidden = messages[21754], messages[21755]
    assert head_lost.head.position == pytest.approx(HEAD_M)  # kept while out of view
    assert head_lost.wand == WandState(pytest.approx((0.31, 0.4, 1.1)),
                                       pytest.approx(messages[21753].wand.orientation), 1,
                                       (0.0, 0.5, 0.0, 0.0))
    assert hidden.wand.position == head_lost.wand.position and hidden.wand.buttons == 16
    report = json.loads((tmp_path / "r.json").read_text())
    early = sent + 4 - report["datagrams"]  # probes sent before the tracker's socket was up
    assert 0 <= early < sent
    assert report == {"datagrams": sent + 4 - early, "published": sent + 2 - early,
                      "rejected": {"not-ascii": 1, "too-large": 1},
                      "missing": {"head": 1, "wand": 1}}
    assert out.strip() == (f"tracker: {sent + 4 - early} datagrams, {sent + 2 - early} "
                           f"published; rejected: not-ascii 1, too-large 1; missing (last pose "
                           f"kept): head 1, wand 1")
    for logged in ("receiving DTrack on udp 127.0.0.1", "first DTrack datagram, from 127.0.0.1",
                   "rejected a DTrack datagram of 11 bytes: not-ascii"):
        assert logged in err
