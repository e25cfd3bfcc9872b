"""`cavesim tracker`: a bridge from an ART DTrack2 system to the session's tracking key.

DTrack2 sends one ASCII UDP datagram per measurement (60-300 Hz) to a port of this host.
Each is parsed and checked (`cavesim.core.tracking.dtrack`), mapped into the CAVE's room
(`cavesim.core.tracking.mapping`), and the latest head and wand are published as a
TrackingMessage on `cavesim/<session>/tracking`, signed when the session has a key: one
per datagram, or at most `max_rate` per second (then the newest state goes out as soon as
the rate allows, never a stale one). The master samples the latest once per frame. A bad
datagram is counted by reason, logged at most once every LOG_INTERVAL s, and changes nothing.
"""

from __future__ import annotations

import logging
import socket
import threading
import time
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field

from cavesim.core.errors import ProtocolError, TrackerError
from cavesim.core.tracking import TrackerMapping, TrackingState, parse_datagram
from cavesim.core.tracking.dtrack import MAX_DATAGRAM
from cavesim.core.wire import Credentials, SessionKeys, TrackingMessage, decode_envelope, encode
from cavesim.core.wire.network import NetworkSettings, open_session

log = logging.getLogger("cavesim.tracker")
POLL = 0.2  # s a receive waits at most, so that Ctrl-C and `stop` are noticed
LOG_INTERVAL = 10.0  # s between two warnings about bad datagrams


@dataclass(frozen=True)
class TrackerConfig:
    port: int  # UDP port DTrack2 sends to
    mapping: TrackerMapping
    bind: str  # address of this host to receive on (0.0.0.0: all)
    session: str = "default"
    network: NetworkSettings = NetworkSettings()
    credentials: Credentials | None = None  # the tracker's own key (tracker-NAME.key)
    max_rate: float = 0.0  # messages per second at most; 0: one per datagram


@dataclass
class TrackerCounts:
    """What a bridge did: datagrams in, messages out, bad datagrams by reason, and the
    datagrams that lacked the head or the wand (its last pose went out instead)."""

    datagrams: int = 0
    published: int = 0
    rejected: Counter[str] = field(default_factory=Counter)
    missing: Counter[str] = field(default_factory=Counter)

    def summary(self) -> dict:
        return {"datagrams": self.datagrams, "published": self.published,
                "rejected": dict(self.rejected), "missing": dict(self.missing)}


class LimitedWarnings:
    """At most one warning every `interval` s; the next one says how many were held back."""

    def __init__(self, interval: float) -> None:
        self.interval, self.quiet_until, self.held = interval, float("-inf"), 0

    def warn(self, now: float, text: str) -> None:
        if now < self.quiet_until:
            self.held += 1
            return
        held = f" ({self.held} more since the last warning)" if self.held else ""
        log.warning("%s%s", text, held)
        self.quiet_until, self.held = now + self.interval, 0


class Bridge:
    """Datagrams in, TrackingMessages out through `publish`, at most `max_rate` per second."""

    def __init__(self, mapping: TrackerMapping, publish: Callable[[TrackingMessage], None],
                 max_rate: float = 0.0) -> None:
        self.state = TrackingState(mapping)
        self.publish = publish
        self.interval = 1.0 / max_rate if max_rate > 0 else 0.0
        self.counts = TrackerCounts()
        self.warnings = LimitedWarnings(LOG_INTERVAL)
        self.frame = 0  # DTrack's frame counter where it sends one, else the datagrams so far
        self.pending = False  # a state not yet published
        self.next_at = float("-inf")  # monotonic s: the rate allows the next message from here

    def receive(self, data: bytes, now: float) -> None:
        """Take one datagram (or count and log why not), then publish if the rate allows."""
        self.counts.datagrams += 1
        try:
            datagram = parse_datagram(data)
        except ProtocolError as e:
            self.counts.rejected[e.reason] += 1
            self.warnings.warn(now, f"rejected a DTrack datagram of {len(data)} bytes: {e}")
            return
        self.counts.missing.update(self.state.update(datagram))
        self.frame = datagram.frame if datagram.frame is not None else self.counts.datagrams
        self.pending = True
        self.flush(now)

    def flush(self, now: float) -> None:
        """Publish the newest state if it has not gone out and the rate allows it now."""
        if self.pending and now >= self.next_at:
            self.publish(self.state.message(self.frame))
            self.counts.published += 1
            self.pending, self.next_at = False, now + self.interval

    def timeout(self, now: float) -> float:
        """How long the next receive may wait (> 0): until a held-back state is due."""
        return min(POLL, self.next_at - now) if self.pending else POLL


class RunFollower:
    """The run id of the master's latest frame (0 before the first, which the master
    refuses): the master takes tracking only of its own run."""

    def __init__(self, session: str, credentials: Credentials | None) -> None:
        self.session, self.credentials, self.run_id = session, credentials, 0

    def on_frame(self, sample) -> None:
        try:
            envelope = decode_envelope(sample.payload.to_bytes(), self.session,
                                       self.credentials)
        except ProtocolError:
            return  # not the master's: the nodes count it
        self.run_id = envelope.run_id


def open_dtrack_socket(bind: str, port: int) -> socket.socket:
    """A UDP socket bound where DTrack2 sends (TrackerError naming the address if not)."""
    udp = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        udp.bind((bind, port))
    except OSError as e:
        udp.close()
        raise TrackerError(f"cannot receive DTrack datagrams on udp {bind}:{port}: "
                           f"{e.strerror or e}; give a free --dtrack port and an address of "
                           f"this host (or 0.0.0.0) for --bind") from e
    return udp


def main(config: TrackerConfig, stop: threading.Event | None = None) -> TrackerCounts:
    """Bridge DTrack to the session until Ctrl-C or `stop`; return what it did."""
    stop = stop or threading.Event()
    key = SessionKeys(config.session).tracking
    with open_dtrack_socket(config.bind, config.port) as udp, \
            open_session(config.network) as session:
        publisher = session.declare_publisher(key, express=True)
        run = RunFollower(config.session, config.credentials)
        frames = session.declare_subscriber(SessionKeys(config.session).frame, run.on_frame)
        bridge = Bridge(config.mapping, lambda m: publisher.put(
            encode(m, config.session, config.credentials, run.run_id)), config.max_rate)
        log.info("receiving DTrack on udp %s:%d, publishing on %s", config.bind, config.port, key)
        try:
            while not stop.is_set():
                now = time.monotonic()
                bridge.flush(now)
                udp.settimeout(bridge.timeout(now))
                try:
                    data, sender = udp.recvfrom(MAX_DATAGRAM + 1)  # a larger one is refused
                except TimeoutError:
                    continue
                first = not bridge.counts.datagrams
                bridge.receive(data, time.monotonic())
                if first:  # said once it is counted
                    log.info("first DTrack datagram, from %s:%d", *sender)
        except KeyboardInterrupt:
            log.info("interrupted")
        finally:
            frames.undeclare()
            publisher.undeclare()
    log.info("tracker done: %s", bridge.counts.summary())
    return bridge.counts
