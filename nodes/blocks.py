"""Block requests over Zenoh: a node answers questions about the state it holds (items of
its checksum's tree, the history of its fold-1 items, single records, the cryptographic
digest of records), and the master (forensics) or a resyncing node (delta resync, and the
confirmation of the state it received) asks them.

A request names the frame and the checksum of the state it is about; a node that holds
another state refuses it (a signed refusal reason, so the asker does not wait). Every
reply is checked against its request before use — sealed for this run, from the node
asked and signed by its key, of the query asked, exactly the data asked for — and a
refused reply is counted.
Sizes are bounded on both sides (`MAX_BLOCK_INDICES`, `MAX_BLOCK_BYTES`); each question
has a deadline.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from typing import Protocol

import numpy as np
import zenoh

from cavesim.core.digest.history import HistoryEntry
from cavesim.core.digest.records_digest import DIGEST_BYTES, RecordsDigest
from cavesim.core.digest.shape import ITEM_WORDS, RECORD_WORDS, plan
from cavesim.core.errors import ProtocolError, StateError
from cavesim.core.wire.credentials import WALL
from cavesim.core.wire.envelope import Envelope, Message
from cavesim.core.wire.network import zenoh_message
from cavesim.core.wire.payloads.state_transfer import (
    MAX_BLOCK_BYTES,
    BlockQuery,
    BlockReply,
    BlockRequest,
    HistoryFrame,
)
from cavesim.core.wire.rejects import RejectCounter
from cavesim.core.wire.replies import asking

log = logging.getLogger("cavesim.blocks")
BLOCK_SECONDS = 5.0  # one question and its reply (4 MiB at most)
BUFFERED_REPLIES = 4  # whole replies one question buffers: the followed one and others'
DIGEST_PIECE = 2**20  # records a DIGEST answer reads from the GPU at once (40 MiB)


class TreeHolder(Protocol):
    """What a node answers block requests from: its current state (a ParticleSystem, or a
    wall simulated in memory)."""

    def tree_state(self) -> tuple[int, int, int]:
        """(seed, live particles, emitters) of the current state."""

    def tree_items(self, level: int, indices: np.ndarray) -> np.ndarray: ...

    def read_records(self, stream: int, indices: np.ndarray) -> bytes: ...

    def history(self, indices: np.ndarray, up_to: int
                ) -> list[tuple[HistoryEntry, np.ndarray]]: ...


def answer(holder: TreeHolder, request: BlockRequest, node: str,
           streams: StreamDigests | None = None) -> BlockReply:
    """The reply to `request` from the state `holder` holds (the caller has checked that it
    is the state the request names; `streams`: its whole streams' digests, each computed
    once); ProtocolError when it asks beyond that state."""
    seed, particles, emitters = holder.tree_state()
    indices = np.asarray(request.indices, dtype=np.int64)
    history: tuple[HistoryFrame, ...] = ()
    try:
        if request.query is BlockQuery.TREE:
            count = plan(particles, emitters).items[request.part]
            if not len(indices):
                indices = np.arange(count)
            _within(indices, count, f"items of level {request.part}")
            _bounded(len(indices) * ITEM_WORDS[request.part] * 4)
            data = holder.tree_items(request.part, indices).astype("<u4").tobytes()
        elif request.query is BlockQuery.RECORDS:
            _within(indices, (particles, emitters)[request.part], "records")
            data = holder.read_records(request.part, indices)
        elif request.query is BlockQuery.DIGEST:
            live = (particles, emitters)[request.part]
            _within(indices, live, "records")
            if len(indices):
                data = held_digest(holder, request.part, indices, live)
            else:
                streams = streams or StreamDigests()
                data = streams.of(holder, (request.frame, request.digest), request.part, live)
        else:
            kept = holder.history(indices, request.frame)
            _bounded(len(kept) * len(indices) * ITEM_WORDS[1] * 4)
            history = tuple(HistoryFrame(e.frame, e.particles, e.emitters) for e, _ in kept)
            data = b"".join(items.astype("<u4").tobytes() for _, items in kept)
    except (StateError, ValueError) as e:
        raise ProtocolError("bad-index", str(e)) from e
    _bounded(len(data))
    return BlockReply(request.frame, node, request.query, request.part, seed, particles,
                      emitters, data, history)


def held_digest(holder: TreeHolder, stream: int, indices: np.ndarray | None,
                live: int) -> bytes:
    """The records digest of `stream`'s records `indices` (None: all `live` of them) as
    `holder` holds them, read a piece at a time."""
    count = live if indices is None else len(indices)
    digest = RecordsDigest(stream, count, indices)
    wanted = np.arange(live) if indices is None else indices
    for first in range(0, count, DIGEST_PIECE):
        digest.update(holder.read_records(stream, wanted[first:first + DIGEST_PIECE]))
    return digest.digest()


class StreamDigests:
    """The digests of the whole streams of the state a node holds, each computed at most
    once for that state (`forget` when the state changes under the same frame and
    checksum): however often a whole stream's digest is asked for, the node reads and
    hashes it once."""

    def __init__(self) -> None:
        self._state: tuple[int, str] | None = None
        self._digests: dict[int, bytes] = {}

    def of(self, holder: TreeHolder, state: tuple[int, str], stream: int, live: int) -> bytes:
        """The digest of `stream` (`live` records) of `holder`'s `state` (frame, checksum)."""
        if state != self._state:
            self.forget()
            self._state = state
        if stream not in self._digests:
            self._digests[stream] = held_digest(holder, stream, None, live)
        return self._digests[stream]

    def forget(self) -> None:
        self._state, self._digests = None, {}


def hashed_bytes(request: BlockRequest) -> int:
    """The bytes of state a DIGEST request naming records has its node read and hash (what
    its asker is charged beside the reply, as if they were sent: at most a RECORDS reply's;
    a whole stream's digest is made once per state, `StreamDigests`)."""
    if request.query is not BlockQuery.DIGEST:
        return 0
    return len(request.indices) * RECORD_WORDS[request.part] * 4


def _within(indices: np.ndarray, count: int, what: str) -> None:
    if len(indices) and indices[-1] >= count:
        raise ProtocolError("bad-index", f"{what} up to {indices[-1]} asked; the state has "
                                         f"{count}")


def _bounded(size: int) -> None:
    if size > MAX_BLOCK_BYTES:
        raise ProtocolError("too-large", f"a reply of {size} bytes; at most {MAX_BLOCK_BYTES}")


def check_reply(message: Message, request: BlockRequest) -> BlockReply:
    """`message` if it is exactly the reply to `request`, else ProtocolError."""
    if not isinstance(message, BlockReply):
        raise ProtocolError("unexpected", f"a {type(message).__name__} as a block reply")
    if (message.frame, message.node, message.query, message.part) != \
            (request.frame, request.node, request.query, request.part):
        raise ProtocolError("wrong-reply", f"a {message.query.name} reply of part "
                                           f"{message.part} from {message.node} of frame "
                                           f"{message.frame} to a {request.query.name} "
                                           f"request of part {request.part} to "
                                           f"{request.node} of frame {request.frame}")
    asked = len(request.indices) or plan(message.particles, message.emitters).items[
        message.part]
    if message.query is BlockQuery.DIGEST:
        expected = DIGEST_BYTES
    elif message.query is BlockQuery.HISTORY:
        frames = [h.frame for h in message.history]
        if frames != sorted(set(frames)) or (frames and frames[-1] > request.frame):
            raise ProtocolError("wrong-reply", f"history frames {frames} are not ascending "
                                               f"up to frame {request.frame}")
        expected = len(message.history) * asked * message.unit
    else:
        expected = asked * message.unit
    if len(message.data) != expected:
        raise ProtocolError("bad-size", f"a {message.query.name} reply of {len(message.data)} "
                                        f"bytes; the request asked for {expected}")
    return message


def serve_blocks(query: zenoh.Query, key: str, holder: TreeHolder, node: str,
                 held: tuple[int, str] | None, request: BlockRequest,
                 seal: Callable[[Message], bytes], streams: StreamDigests | None = None) -> int:
    """Answer one block request about the state `held` (frame, checksum) names, or refuse
    it with a reason (another state, beyond the state, too large); the bytes sent and, for a
    DIGEST of records named, the bytes hashed (which the asker's serving budget is
    charged)."""
    try:
        try:
            if held != (request.frame, request.digest):
                raise ProtocolError("not-held", f"asked about frame {request.frame} "
                                                f"({request.digest[:8]}); this node holds "
                                                f"{held[0] if held else 'no'} frame")
            reply = seal(answer(holder, request, node, streams))
            query.reply(key, reply)
            return len(reply) + hashed_bytes(request)
        except ProtocolError as e:
            query.reply_err(str(e))
    except zenoh.ZError as e:  # the asker went away
        log.info("%s: a block reply failed: %s", node, zenoh_message(e))
    finally:
        query.drop()
    return 0


class BlockAsker:
    """Asks one node's `blocks/<node>` key, following one replier: the first whose reply
    checks out. A replier whose reply is refused (counted) is not heard again (`failed`,
    which the caller may share with a snapshot fetch); `bytes` counts what went each way.
    Each question waits at most BLOCK_SECONDS, and none goes out past `deadline` (a
    monotonic time) if one is given."""

    def __init__(self, session: zenoh.Session, key: str, seal: Callable[[Message], bytes],
                 open_reply: Callable[[bytes], Envelope], rejects: RejectCounter,
                 failed: set[str] | None = None, deadline: float | None = None) -> None:
        self.session, self.key, self.seal, self.open_reply = session, key, seal, open_reply
        self.rejects, self.deadline = rejects, deadline
        self.failed = set() if failed is None else failed
        self.replier: str | None = None
        self.bytes = 0
        self.refusal: str | None = None  # the node's last reason for refusing

    def __call__(self, request: BlockRequest) -> BlockReply | None:
        """The checked reply to `request`, or None (refused, no answer, or past the
        deadline)."""
        now = time.monotonic()
        deadline = now + BLOCK_SECONDS if self.deadline is None \
            else min(now + BLOCK_SECONDS, self.deadline)
        if deadline <= now:
            return None
        payload = self.seal(request)
        self.bytes += len(payload)

        def listen(replier: str) -> bool:
            return replier not in self.failed and self.replier in (None, replier)

        with asking(self.session, self.key, deadline, BUFFERED_REPLIES * MAX_BLOCK_BYTES,
                    listen, payload=payload,
                    consolidation=zenoh.ConsolidationMode.NONE) as replies:
            for reply in replies:
                if reply.ok is None:
                    self.refusal = reply.err.payload.to_string()
                    continue
                replier = str(reply.replier_id)
                if not listen(replier):
                    continue
                data = reply.ok.payload.to_bytes()
                try:
                    envelope = self.open_reply(data)
                    envelope.check_signer(WALL, request.node)
                    checked = check_reply(envelope.message, request)
                except ProtocolError as e:
                    self.rejects.reject(e, self.key)
                    self.failed.add(replier)
                    continue
                self.replier = replier
                self.bytes += len(data)
                return checked
        return None
