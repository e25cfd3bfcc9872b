"""The master's side of the wire over Zenoh: typed events in, messages out.

Zenoh callbacks decode and check on Zenoh's threads, so nothing unchecked is ever queued: a
message must carry this run's id (`run_id`, drawn by the master), come from the wall its
key names and signed by that wall's own key (with keys), and a report may only be of a
frame already sent. Refusals are counted (and
logged at a bounded rate), never queued; a wall whose every message fails its signature, or
that refuses the master's signed queries, is named with a hint about --key-file. The event
queue is bounded: when the master falls that far behind, further events are dropped and
counted (the barrier asks again). Only the latest tracking message is kept (the latest
pose, and the latest session controls of a preview window, with their sender), and only one
of this run, signed by a tracker or an operator, fresh and newer than its sender's last;
session controls only an operator's (`not-an-operator`: a wall's or a tracker's message
that carries them is refused whole, its pose too). The master's
liveliness token, keyed by its run id, tells the nodes it is there; another master's token
becomes OtherMaster (one master per session), and liveliness of the session's walls
WallUp/WallDown. Nothing a callback raises reaches Zenoh's thread
(`RejectCounter.guarded`).
"""

from __future__ import annotations

import dataclasses
import logging
import queue
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager

import zenoh

from cavesim.core.errors import ProtocolError
from cavesim.core.wire import (
    BlockReply,
    BlockRequest,
    ControlMessage,
    Credentials,
    DisplayMessage,
    FrameMessage,
    InfoMessage,
    InfoRequest,
    ReportMessage,
    SessionKeys,
    TrackingMessage,
    decode_envelope,
    encode,
)
from cavesim.core.wire.credentials import OPERATOR, TRACKER, WALL, Identity
from cavesim.core.wire.envelope import Envelope, new_run_id
from cavesim.core.wire.guards import KeyMismatch
from cavesim.core.wire.network import lockstep_publisher, open_session
from cavesim.core.wire.payloads.poses import MAX_TRACKING_AGE
from cavesim.core.wire.payloads.state_transfer import MASTER_ASKER
from cavesim.core.wire.rejects import RejectCounter
from nodes.blocks import BlockAsker
from nodes.master.events import (
    Described,
    Displayed,
    Event,
    OtherMaster,
    Reported,
    WallDown,
    WallUp,
)
from nodes.master.user_requests import Controller

log = logging.getLogger("cavesim.master")
TRACKING_ROLES = (TRACKER, OPERATOR)  # whose keys may send the head and the wand
CONTROLLING_ROLES = (OPERATOR,)  # whose keys may send session controls
INFO_TIMEOUT = 10.0  # s a wall has to say which GPU it computes on
EVENT_QUEUE = 4096  # events the master's loop may fall behind by


class ZenohMasterLink:
    def __init__(self, session: zenoh.Session, name: str, credentials: Credentials | None,
                 walls: tuple[str, ...], run_id: int) -> None:
        self.session, self.name, self.credentials, self.walls = session, name, credentials, walls
        self.run_id = run_id
        self.keys = SessionKeys(name)
        self.events: queue.Queue[Event] = queue.Queue(maxsize=EVENT_QUEUE)
        self.rejects = RejectCounter("master")
        self.mismatch = KeyMismatch("master")
        self.dropped = 0  # events the full queue could not take
        self.tracking: TrackingMessage | None = None  # the latest pose; the master samples it
        self.controller: Controller | None = None  # the latest session controls, and whose
        self._tracking_sent: dict[Identity | None, int] = {}  # per signer: the last taken
        self.last_sent = 0  # the newest frame sent: a report of a later one is refused
        self._lock = threading.Lock()
        self._frames = lockstep_publisher(session, self.keys.frame)
        self._control = lockstep_publisher(session, self.keys.control)
        guarded = self.rejects.guarded
        self._declarations = [
            session.declare_subscriber(self.keys.report(), guarded("a report", self._on_report)),
            session.declare_subscriber(self.keys.display(),
                                       guarded("a display message", self._on_display)),
            session.declare_subscriber(self.keys.tracking,
                                       guarded("a tracking message", self._on_tracking)),
            session.liveliness().declare_subscriber(
                self.keys.alive(), guarded("a wall's liveliness", self._on_alive),
                history=True),
            session.liveliness().declare_subscriber(
                self.keys.master_alive(), guarded("a master's liveliness", self._on_master),
                history=True),
            session.liveliness().declare_token(self.keys.master_alive(run_id)),
        ]

    def send(self, message: FrameMessage | ControlMessage) -> None:
        if isinstance(message, FrameMessage):
            self.last_sent = max(self.last_sent, message.frame)
            publisher = self._frames
        else:
            publisher = self._control
        publisher.put(self._seal(message))

    def ask_info(self, wall: str) -> None:
        """Ask `wall` which GPU it computes on and for its nonce; the answer is an event."""
        self.session.get(self.keys.info(wall), self.rejects.guarded(
            f"{wall}'s info reply", lambda reply: self._on_info(wall, reply)),
            timeout=INFO_TIMEOUT, payload=self._seal(InfoRequest(0, wall)))

    def ask_blocks(self, wall: str, request: BlockRequest) -> BlockReply | None:
        """`wall`'s reply to a block request about its state (desync forensics), checked and
        of this run; None when it refused or did not answer in time (BLOCK_SECONDS)."""
        asker = BlockAsker(self.session, self.keys.blocks(wall), self._seal,
                           self._open_reply, self.rejects)
        reply = asker(request)
        if reply is None:
            log.warning("%s did not answer a %s block question: %s", wall, request.query.name,
                        asker.refusal or "no reply in time")
        return reply

    def sender_hint(self, wall: str) -> str | None:
        """Why `wall` may not be heard: its messages fail their signature (else None)."""
        return self.mismatch.hint(f"wall {wall}")

    def close(self) -> None:
        for declaration in reversed(self._declarations):
            declaration.undeclare()

    def _seal(self, message) -> bytes:
        if isinstance(message, BlockRequest):  # whose budget it spends there
            message = dataclasses.replace(message, asker=MASTER_ASKER)
        return encode(message, self.name, self.credentials, self.run_id)

    def _open_reply(self, data: bytes) -> Envelope:
        """A reply to one of our queries, checked: of this run (whose key signed it, the
        asker checks)."""
        envelope = decode_envelope(data, self.name, self.credentials)
        if envelope.run_id != self.run_id:
            raise ProtocolError("wrong-run", f"a reply of run {envelope.run_id:#018x}")
        return envelope

    # -- zenoh callbacks: decode, check, enqueue ------------------------------------------

    def _post(self, event: Event) -> None:
        try:
            self.events.put_nowait(event)
        except queue.Full:
            with self._lock:
                self.dropped += 1

    def _on_alive(self, sample: zenoh.Sample) -> None:
        wall = self.keys.node_of(sample.key_expr)
        if wall in self.walls:
            up = sample.kind == zenoh.SampleKind.PUT
            self._post(WallUp(wall) if up else WallDown(wall))

    def _on_master(self, sample: zenoh.Sample) -> None:
        """Another master's token came: the master decides (it refuses to start, or keeps
        its run); its going away changes nothing here."""
        run_id = self.keys.run_of(sample.key_expr)
        if run_id is None:
            self._reject(ProtocolError("bad-master-token", "a master's liveliness token "
                                                           "without a run id"), sample)
        elif run_id != self.run_id and sample.kind == zenoh.SampleKind.PUT:
            self._post(OtherMaster(run_id, str(sample.key_expr)))

    def _on_report(self, sample: zenoh.Sample) -> None:
        report = self._from_wall(sample, ReportMessage, "report")
        if report is None:
            return
        if report.frame > self.last_sent:
            self._reject(ProtocolError("unsent-frame", f"a report of frame {report.frame}; "
                                                       f"the newest frame sent is "
                                                       f"{self.last_sent}"), sample)
            return
        self._post(Reported(report))

    def _on_display(self, sample: zenoh.Sample) -> None:
        if (message := self._from_wall(sample, DisplayMessage, "display")) is not None:
            self._post(Displayed(message))

    def _on_info(self, wall: str, reply: zenoh.Reply) -> None:
        if reply.ok is None:  # the wall's refusal (our signature failed there), or a timeout
            reason = reply.err.payload.to_string()
            log.info("the info query to %s got no answer: %s", wall, reason)
            if hint := self.mismatch.note(f"wall {wall}", reason):
                log.error("master: %s", hint)
            return
        if (info := self._from_wall(reply.ok, InfoMessage, "info")) is not None:
            self._post(Described(info))

    def _on_tracking(self, sample: zenoh.Sample) -> None:
        try:
            envelope = decode_envelope(sample.payload.to_bytes(), self.name,
                                       self.credentials)
            message = envelope.message
        except ProtocolError as e:
            self._reject(e, sample)
            return
        if isinstance(message, TrackingMessage):
            try:
                self._check_tracking(envelope, message)
            except ProtocolError as e:
                self._reject(e, sample)
                return
            if message.posed:
                self.tracking = message
            if message.controls is not None:
                self.controller = Controller(message, envelope.signer)
        else:
            self._reject(ProtocolError("unexpected", f"a {type(message).__name__} on the "
                                                     f"tracking key"), sample)

    def _check_tracking(self, envelope: Envelope, message: TrackingMessage) -> None:
        """ProtocolError unless `message` is of this run, signed with keys by a tracker or an
        operator (and its session controls, if any, by an operator), sent within
        MAX_TRACKING_AGE of now and after the last one its sender had taken."""
        if envelope.run_id != self.run_id:
            raise ProtocolError("wrong-run", f"tracking of run {envelope.run_id:#018x}, this "
                                             f"run is {self.run_id:#018x}")
        role = envelope.signer.role if envelope.signer is not None else None
        if envelope.keyed and message.controls is not None and role not in CONTROLLING_ROLES:
            raise ProtocolError("not-an-operator", f"session controls signed by "
                                                   f"{envelope.signer or 'no member'}: only an "
                                                   f"operator's key may pause, reset or stop "
                                                   f"the run")
        if envelope.keyed and role not in TRACKING_ROLES:
            raise ProtocolError("wrong-signer", f"tracking signed by "
                                                f"{envelope.signer or 'no member'}: only a "
                                                f"tracker's or an operator's key sends it")
        age = time.time() - message.sent_ns / 1e9
        if abs(age) > MAX_TRACKING_AGE:
            raise ProtocolError("stale-tracking", f"sent {age:.1f} s ago; at most "
                                                  f"{MAX_TRACKING_AGE} s either way")
        last = self._tracking_sent.get(envelope.signer, 0)
        if message.sent_ns <= last:
            raise ProtocolError("replayed-tracking", f"sent at {message.sent_ns} ns, not "
                                                     f"after the last taken ({last} ns)")
        self._tracking_sent[envelope.signer] = message.sent_ns

    def _from_wall(self, sample: zenoh.Sample, expected: type, key: str):
        """The message if it is an `expected` of this run from the wall its key names."""
        sender = self.keys.node_of(sample.key_expr)
        if sender not in self.walls:
            self._reject(ProtocolError("unknown-wall", f"{sender!r} is not a wall of this "
                                                       f"run"), sample)
            return None
        try:
            envelope = decode_envelope(sample.payload.to_bytes(), self.name, self.credentials)
        except ProtocolError as e:
            self._reject(e, sample, f"wall {sender}")
            return None
        self.mismatch.note(f"wall {sender}", None)
        message = envelope.message
        if envelope.run_id != self.run_id:
            self._reject(ProtocolError("wrong-run", f"run {envelope.run_id:#018x}, this run "
                                                    f"is {self.run_id:#018x}"), sample)
        elif not isinstance(message, expected) or message.node != sender:
            self._reject(ProtocolError("unexpected", f"{type(message).__name__} from "
                                                     f"{sender!r} on a {key} key"), sample)
        else:
            try:
                envelope.check_signer(WALL, sender)  # an insider speaks for its wall only
            except ProtocolError as e:
                self._reject(e, sample)
                return None
            return message
        return None

    def _reject(self, error: ProtocolError, sample: zenoh.Sample,
                sender: str | None = None) -> None:
        self.rejects.reject(error, str(sample.key_expr))
        if sender is not None and (hint := self.mismatch.note(sender, error.reason)):
            log.error("master: %s", hint)


@contextmanager
def open_master_link(config, run_id: int | None = None) -> Iterator[ZenohMasterLink]:
    """A Zenoh session with the master's declarations, for the length of one run (a new
    run id unless one is given)."""
    run_id = run_id or new_run_id()
    with open_session(config.network) as session:
        link = ZenohMasterLink(session, config.session, config.credentials, config.walls,
                               run_id)
        try:
            yield link
        finally:
            link.close()
