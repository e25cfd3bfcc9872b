"""What reaches a wall node's main thread, checked first on Zenoh's threads.

Nothing unchecked is queued: a frame or a command must carry the master's signature (in a
session with credentials) and this run's id, a WELCOME this node's own fresh nonce (and, once
the node is in a run, that run's master must be gone: a node never leaves a live master for
another; the masters' liveliness tokens, keyed by run id, say which are there), a frame
must not be older than the node's, a command not older than the newest frame the master
sent (a RESYNC replayed from earlier in the same run is refused); a state or block query
must be signed, of this run, for this wall and not of a frame older than the node's; an info
query must be the master's. Every query's nonce is taken once: a replayed query is refused
before it costs anything. Refusals are counted (and logged at a bounded rate), and a sender
whose every message fails its signature is named with a hint about --key-file; nothing a
callback raises reaches Zenoh's thread (`RejectCounter.guarded`). Queries are answered
within a budget per asker (requests and bytes per second; an info query's asker is the
master of its run), so one peer's flood cannot starve another's resync, and dropped and
counted when the main thread is behind. The master's frames and commands are never
dropped: when the queue is full, Zenoh's thread waits for the main thread; copies of a
frame already queued (the master sends one again after a barrier stall) are let through at
most one per REPEAT_SPACING.
"""

from __future__ import annotations

import logging
import queue
import threading
import time
from collections import Counter
from dataclasses import dataclass

import zenoh

from cavesim.core.errors import ProtocolError
from cavesim.core.wire import (
    BlockRequest,
    Command,
    ControlMessage,
    Credentials,
    FrameMessage,
    InfoRequest,
    SessionKeys,
    StateRequest,
    decode_envelope,
)
from cavesim.core.wire.credentials import WALL, Identity
from cavesim.core.wire.guards import SIGNATURE_REASONS, FreshNonces, KeyMismatch, ServingBudget
from cavesim.core.wire.payloads.state_transfer import MASTER_ASKER
from cavesim.core.wire.rejects import RejectCounter

log = logging.getLogger("cavesim.node")
QUEUE = 256  # events the main thread may fall behind by
# per asker: requests per second, at once, and bytes per second (also at once)
STATE_RATE, STATE_BURST, STATE_BYTES = 1.0, 2, 64 * 2**20  # a snapshot may be megabytes
BLOCK_RATE, BLOCK_BURST, BLOCK_BYTES = 20.0, 40, 32 * 2**20  # a forensics or delta asks a few
INFO_RATE, INFO_BURST, INFO_BYTES = 5.0, 5, 2**20  # per run: an old run's replays spend its own
REPEAT_SPACING = 0.25  # s between copies of a queued frame let through (the master's: 2 s)
MASTER = "the master"  # the sender named in a --key-file hint


@dataclass
class NodeView:
    """What the checks need of the node's state; the main thread writes it."""

    wall: str
    nonce: int  # the nonce of the node's last info answer: a WELCOME must name it
    run_id: int | None = None  # the run it joined
    done: int = 0  # the last frame whose state it holds
    heard: int = 0  # the newest frame of the run the master sent: no command is older


@dataclass(frozen=True)
class FromMaster:
    """A frame or command of the current run (or a WELCOME naming our nonce)."""

    message: FrameMessage | ControlMessage
    run_id: int


@dataclass(frozen=True)
class StateQuery:
    query: zenoh.Query
    request: StateRequest


@dataclass(frozen=True)
class BlocksQuery:
    """A question about the state this node holds (desync forensics, a delta resync)."""

    query: zenoh.Query
    request: BlockRequest


@dataclass(frozen=True)
class InfoQuery:
    query: zenoh.Query
    run_id: int  # of the master asking: the answer carries it back


@dataclass(frozen=True)
class MasterPresence:
    """The liveliness token of the master of run `run_id` appeared (True) or went away."""

    run_id: int
    up: bool


NodeEvent = FromMaster | StateQuery | BlocksQuery | InfoQuery | MasterPresence


def asker(event: StateQuery | BlocksQuery | InfoQuery) -> str | int:
    """Whose serving budget a query is charged to: a request's asker, an info query's run."""
    return event.run_id if isinstance(event, InfoQuery) else event.request.asker


class NodeInbox:
    def __init__(self, session_name: str, credentials: Credentials | None,
                 view: NodeView) -> None:
        self.session_name, self.credentials, self.view = session_name, credentials, view
        self.keys = SessionKeys(session_name)
        self.rejects = RejectCounter(f"node {view.wall}")
        self.mismatch = KeyMismatch(f"node {view.wall}")
        self.dropped: Counter[str] = Counter()  # queries the full queue could not take
        self._budgets = {StateQuery: ServingBudget(STATE_RATE, STATE_BURST, STATE_BYTES,
                                                   STATE_BYTES),
                         BlocksQuery: ServingBudget(BLOCK_RATE, BLOCK_BURST, BLOCK_BYTES,
                                                    BLOCK_BYTES),
                         InfoQuery: ServingBudget(INFO_RATE, INFO_BURST, INFO_BYTES,
                                                  INFO_BYTES)}
        self._nonces = FreshNonces()
        self._copy_at = -REPEAT_SPACING  # when the last copy of a queued frame was queued
        self._queue: queue.Queue[NodeEvent] = queue.Queue(maxsize=QUEUE)
        self._lock = threading.Lock()
        self._masters: set[int] = set()  # the runs whose master's token is there

    def declare(self, session: zenoh.Session, keys: SessionKeys) -> list:
        wall, guarded = self.view.wall, self.rejects.guarded
        return [
            session.declare_subscriber(keys.frame, guarded("a frame", self._on_frame)),
            session.declare_subscriber(keys.control, guarded("a command", self._on_control)),
            session.declare_queryable(keys.state(wall),
                                      guarded("a state query", self._on_state_query)),
            session.declare_queryable(keys.blocks(wall),
                                      guarded("a block query", self._on_blocks_query)),
            session.declare_queryable(keys.info(wall),
                                      guarded("an info query", self._on_info_query)),
            session.liveliness().declare_subscriber(
                keys.master_alive(), guarded("the master's liveliness", self._on_master),
                history=True),
        ]

    def get(self, timeout: float | None) -> NodeEvent | None:
        try:
            return self._queue.get(timeout=timeout)
        except queue.Empty:
            return None

    def spent(self, event: StateQuery | BlocksQuery | InfoQuery, size: int) -> None:
        """Charge the bytes that answering `event` sent to its asker's budget."""
        self._budgets[type(event)].spend(asker(event), size)

    def master_hint(self) -> str | None:
        return self.mismatch.hint(MASTER)

    def refuses_hop(self, run_id: int, where: str) -> bool:
        """Whether a WELCOME into run `run_id` is refused (and counted): a node stays in
        the run it joined while that run's master is alive, whatever another master says."""
        joined = self.view.run_id
        if joined is None or run_id == joined or not self._master_alive(joined):
            return False
        self._reject(ProtocolError("other-master", f"a WELCOME into run {run_id:#018x}; "
                                                   f"this node is in run {joined:#018x}, "
                                                   f"whose master is alive"), where)
        return True

    # -- zenoh callbacks ---------------------------------------------------------------

    def _on_frame(self, sample: zenoh.Sample) -> None:
        where, view = str(sample.key_expr), self.view
        envelope = self._from_master(sample, FrameMessage, "frame")
        if envelope is None or not self._of_this_run(envelope.run_id, where):
            return
        message = envelope.message
        if message.frame < view.done:
            self._reject(ProtocolError("stale-frame", f"frame {message.frame}, this node "
                                                      f"holds {view.done}"), where)
        elif message.frame <= view.heard and not self._copy_due():
            self._reject(ProtocolError("repeated-frame", f"another copy of frame "
                                                         f"{message.frame} within "
                                                         f"{REPEAT_SPACING} s"), where)
        else:
            view.heard = max(view.heard, message.frame)
            self._queue.put(FromMaster(message, envelope.run_id))  # waits, never drops

    def _copy_due(self) -> bool:
        """Whether a copy of a frame already queued may go through now (one at a time)."""
        with self._lock:
            now = time.monotonic()
            if now - self._copy_at < REPEAT_SPACING:
                return False
            self._copy_at = now
            return True

    def _on_control(self, sample: zenoh.Sample) -> None:
        where, view = str(sample.key_expr), self.view
        envelope = self._from_master(sample, ControlMessage, "control")
        if envelope is None:
            return
        message = envelope.message
        if message.command in (Command.WELCOME, Command.RESYNC) and message.target != view.wall:
            return  # another wall's
        if message.command is Command.WELCOME:
            if message.nonce != view.nonce:
                self._reject(ProtocolError("stale-welcome", "a WELCOME naming a nonce this "
                                                            "node does not hold (a replay)"),
                             where)
            elif not self.refuses_hop(envelope.run_id, where):
                self._queue.put(FromMaster(message, envelope.run_id))
        elif self._of_this_run(envelope.run_id, where):
            if message.frame < view.heard:  # the master's commands name the frame in flight
                self._reject(ProtocolError("stale-command", f"a {message.command.name} of "
                                                            f"frame {message.frame}; the "
                                                            f"run is at {view.heard}"), where)
            else:
                self._queue.put(FromMaster(message, envelope.run_id))

    def _on_state_query(self, query: zenoh.Query) -> None:
        where = str(query.key_expr)  # a dropped query's key can no longer be read
        request = self._peer_request(query, where, StateRequest, "state")
        if request is not None:
            self._offer(StateQuery(query, request), query, where)

    def _on_blocks_query(self, query: zenoh.Query) -> None:
        where = str(query.key_expr)
        request = self._peer_request(query, where, BlockRequest, "block")
        if request is not None:
            self._offer(BlocksQuery(query, request), query, where)

    def _peer_request(self, query: zenoh.Query, where: str, expected: type, what: str):
        """The request of a signed, fresh query of this run for this wall about a state it
        may still hold, or None (refused and counted, the query dropped)."""
        envelope = self._request(query, where, expected)
        if envelope is None:
            return None
        request, view = envelope.message, self.view
        if envelope.run_id != view.run_id or request.node != view.wall:
            error = ProtocolError("wrong-run", f"a {what} query of another run or wall")
        elif envelope.keyed and request.asker not in ("", MASTER_ASKER) \
                and envelope.signer != Identity(WALL, request.asker):  # a wall's own budget
            error = ProtocolError("wrong-signer", f"a {what} query in the name of "
                                                  f"{request.asker!r} signed by "
                                                  f"{envelope.signer or 'no member'}")
        elif not self._nonces.take(request.nonce):
            error = ProtocolError("replayed-query", f"a {what} query whose nonce was taken "
                                                    f"before")
        elif request.frame < view.done:
            error = ProtocolError("stale-query", f"a {what} query of frame {request.frame}; "
                                                 f"this node holds frame {view.done}")
        else:
            return request
        self._refuse(query, error, where)
        return None

    def _on_info_query(self, query: zenoh.Query) -> None:
        where = str(query.key_expr)
        envelope = self._request(query, where, InfoRequest, tell_signature_failures=True)
        if envelope is None:
            return
        if not self._nonces.take(envelope.message.nonce):
            self._refuse(query, ProtocolError("replayed-query", "an info query whose nonce "
                                                                "was taken before"), where)
        else:
            self._offer(InfoQuery(query, envelope.run_id), query, where)

    def _on_master(self, sample: zenoh.Sample) -> None:
        where = str(sample.key_expr)
        run_id = self.keys.run_of(where)
        if run_id is None:
            self._reject(ProtocolError("bad-master-token", "a master's liveliness token "
                                                           "without a run id"), where)
            return
        up = sample.kind == zenoh.SampleKind.PUT
        with self._lock:
            if up:
                self._masters.add(run_id)
            else:
                self._masters.discard(run_id)
        self._queue.put(MasterPresence(run_id, up))

    def _master_alive(self, run_id: int | None) -> bool:
        with self._lock:
            return run_id in self._masters

    # -- checks ------------------------------------------------------------------------

    def _open(self, data: bytes, where: str, sender: str = MASTER,
              query: zenoh.Query | None = None):
        try:
            envelope = decode_envelope(data, self.session_name, self.credentials)
        except ProtocolError as e:
            self._reject(e, where, sender)
            if query is not None and e.reason in SIGNATURE_REASONS:
                query.reply_err(e.reason)
            return None
        self.mismatch.note(sender, None)
        return envelope

    def _from_master(self, sample: zenoh.Sample, expected: type, key: str):
        """The checked envelope of a message of type `expected` on the `key` key, or None."""
        envelope = self._open(sample.payload.to_bytes(), str(sample.key_expr))
        if envelope is not None and not isinstance(envelope.message, expected):
            self._reject(ProtocolError("unexpected", f"a {type(envelope.message).__name__} "
                                                     f"on the {key} key"), str(sample.key_expr))
            return None
        return envelope

    def _of_this_run(self, run_id: int, where: str) -> bool:
        joined = self.view.run_id
        if joined is None:
            self._reject(ProtocolError("not-joined", "a message of a run this node has not "
                                                     "joined"), where)
            return False
        if run_id != joined:
            if self._master_alive(run_id):  # a master beside ours: the node stays in its run
                error = ProtocolError("other-master", f"run {run_id:#018x} of another "
                                                      f"master, this node's is {joined:#018x}")
            else:
                error = ProtocolError("wrong-run", f"run {run_id:#018x}, this node's is "
                                                   f"{joined:#018x}")
            self._reject(error, where)
            return False
        return True

    def _request(self, query: zenoh.Query, where: str, expected: type,
                 tell_signature_failures: bool = False):
        """The query's checked request envelope, or None (the query is then dropped; with
        `tell_signature_failures`, a signature failure is first answered with its reason, so
        that the master can tell that the keys do not match)."""
        payload = query.payload
        sender = MASTER if expected is InfoRequest else "a peer"
        if payload is None:
            envelope = self._reject(ProtocolError("unsigned", "a query without a request"),
                                    where)
        else:
            envelope = self._open(payload.to_bytes(), where, sender,
                                  query if tell_signature_failures else None)
        if envelope is not None and not isinstance(envelope.message, expected):
            self._reject(ProtocolError("unexpected", f"a {type(envelope.message).__name__} "
                                                     f"as a {expected.__name__}"), where)
            envelope = None
        if envelope is None:
            query.drop()
        return envelope

    def _offer(self, event: StateQuery | BlocksQuery | InfoQuery, query: zenoh.Query,
               where: str) -> None:
        """Queue a checked query for the main thread, within its asker's budget (refused
        and counted above it) and while the queue has room (dropped and counted when
        full)."""
        if not self._budgets[type(event)].admit(asker(event)):
            self._refuse(query, ProtocolError("over-budget", f"more {type(event).__name__}s "
                                                             f"than this node serves "
                                                             f"{asker(event)!r} per second"),
                         where)
            return
        try:
            self._queue.put_nowait(event)
        except queue.Full:
            query.drop()
            with self._lock:
                self.dropped[type(event).__name__] += 1

    def _refuse(self, query: zenoh.Query, error: ProtocolError, where: str) -> None:
        """Count a refused query and drop it: it is answered by nothing."""
        self._reject(error, where)
        query.drop()

    def _reject(self, error: ProtocolError, where: str, sender: str | None = None) -> None:
        self.rejects.reject(error, where)
        if sender is not None and (hint := self.mismatch.note(sender, error.reason)):
            log.error("%s: %s", self.view.wall, hint)
