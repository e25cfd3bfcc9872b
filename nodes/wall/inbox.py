"""What reaches a wall node's main thread, checked first on Zenoh's threads.

Nothing unchecked is queued: a frame or a command must carry the master's signature (in a
session with credentials) and this run's id, a WELCOME this node's own fresh nonce (and, once
the node is in a run, that run's master must be gone: a node never leaves a live master for
another; the masters' liveliness tokens, keyed by run id, say which are there), a frame
must not be older than the node's, a command not older than the newest frame the master
sent (a RESYNC replayed from earlier in the same run is refused); a state or block query
must be signed, of this run and for this wall; an info query must be the master's. Refusals are
counted (and logged at a bounded rate), and a sender whose every message fails its
signature is named with a hint about --key-file. Queries are answered at a bounded rate,
and dropped and counted when the main thread is behind; the master's frames and commands
are never dropped: when the queue is full, Zenoh's thread waits for the main thread.
"""

from __future__ import annotations

import logging
import queue
import threading
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
from cavesim.core.wire.guards import SIGNATURE_REASONS, KeyMismatch, RateLimit
from cavesim.core.wire.rejects import RejectCounter

log = logging.getLogger("cavesim.node")
QUEUE = 256  # events the main thread may fall behind by
STATE_RATE, STATE_BURST = 1.0, 2  # snapshots served per second: each may be megabytes
INFO_RATE, INFO_BURST = 5.0, 5
BLOCK_RATE, BLOCK_BURST = 20.0, 40  # block questions: a forensics or a delta asks a few
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


class NodeInbox:
    def __init__(self, session_name: str, credentials: Credentials | None,
                 view: NodeView) -> None:
        self.session_name, self.credentials, self.view = session_name, credentials, view
        self.keys = SessionKeys(session_name)
        self.rejects = RejectCounter(f"node {view.wall}")
        self.mismatch = KeyMismatch(f"node {view.wall}")
        self.dropped: Counter[str] = Counter()  # queries the full queue could not take
        self._limits = {StateQuery: RateLimit(STATE_RATE, STATE_BURST),
                        BlocksQuery: RateLimit(BLOCK_RATE, BLOCK_BURST),
                        InfoQuery: RateLimit(INFO_RATE, INFO_BURST)}
        self._queue: queue.Queue[NodeEvent] = queue.Queue(maxsize=QUEUE)
        self._lock = threading.Lock()
        self._masters: set[int] = set()  # the runs whose master's token is there

    def declare(self, session: zenoh.Session, keys: SessionKeys) -> list:
        wall = self.view.wall
        return [
            session.declare_subscriber(keys.frame, self._on_frame),
            session.declare_subscriber(keys.control, self._on_control),
            session.declare_queryable(keys.state(wall), self._on_state_query),
            session.declare_queryable(keys.blocks(wall), self._on_blocks_query),
            session.declare_queryable(keys.info(wall), self._on_info_query),
            session.liveliness().declare_subscriber(keys.master_alive(), self._on_master,
                                                    history=True),
        ]

    def get(self, timeout: float | None) -> NodeEvent | None:
        try:
            return self._queue.get(timeout=timeout)
        except queue.Empty:
            return None

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
        else:
            view.heard = max(view.heard, message.frame)
            self._queue.put(FromMaster(message, envelope.run_id))  # waits, never drops

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
        request = self._peer_request(query, StateRequest, "state")
        if request is not None:
            self._offer(StateQuery(query, request), query)

    def _on_blocks_query(self, query: zenoh.Query) -> None:
        request = self._peer_request(query, BlockRequest, "block")
        if request is not None:
            self._offer(BlocksQuery(query, request), query)

    def _peer_request(self, query: zenoh.Query, expected: type, what: str):
        """The request of a signed query of this run for this wall, or None (dropped)."""
        request = self._request(query, expected)
        if request is None:
            return None
        if request.run_id != self.view.run_id or request.message.node != self.view.wall:
            query.drop()
            self._reject(ProtocolError("wrong-run", f"a {what} query of another run or wall"),
                         str(query.key_expr))
            return None
        return request.message

    def _on_info_query(self, query: zenoh.Query) -> None:
        request = self._request(query, InfoRequest, tell_signature_failures=True)
        if request is not None:
            self._offer(InfoQuery(query, request.run_id), query)

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

    def _request(self, query: zenoh.Query, expected: type,
                 tell_signature_failures: bool = False):
        """The query's checked request envelope, or None (the query is then dropped; with
        `tell_signature_failures`, a signature failure is first answered with its reason, so
        that the master can tell that the keys do not match)."""
        where = str(query.key_expr)
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

    def _offer(self, event: StateQuery | BlocksQuery | InfoQuery, query: zenoh.Query) -> None:
        """Queue a checked query for the main thread, within its kind's rate (refused and
        counted above it) and while the queue has room (dropped and counted when full)."""
        if not self._limits[type(event)].allow():
            query.drop()
            self._reject(ProtocolError("rate-limited", f"more {type(event).__name__}s than "
                                                       f"this node answers per second"),
                         str(query.key_expr))
            return
        try:
            self._queue.put_nowait(event)
        except queue.Full:
            query.drop()
            with self._lock:
                self.dropped[type(event).__name__] += 1

    def _reject(self, error: ProtocolError, where: str, sender: str | None = None) -> None:
        self.rejects.reject(error, where)
        if sender is not None and (hint := self.mismatch.note(sender, error.reason)):
            log.error("%s: %s", self.view.wall, hint)
