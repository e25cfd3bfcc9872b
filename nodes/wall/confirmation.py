"""A received state confirmed by a second wall before it is committed (a part of a resync,
`nodes/wall/state_service.py`).

The per-frame checksum proves that honest walls agree, not that a state was not built to
match it: a source that is an insider (or whose key was stolen) can serve a state with the
named checksum and other particles. So the master names a confirmer in its RESYNC, a second
member holding the agreed state. Before the node commits what it received, by snapshot or by
delta, it hashes those records (cavesim/core/digest/records_digest.py) and asks the
confirmer for the digest of the same records, which the confirmer computes from its own GPU
state and signs with its own key (a DIGEST block question). The digests, the seed and the
live counts must all be equal, else the state is refused (`unconfirmed`, counted); a
confirmer that does not answer ends the resync (`NoConfirmation`): the master then tries
another source. Where no second wall holds the state, the master names nobody, the state is
committed unconfirmed, and the node's log and report.json say so.
"""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np

from cavesim.core.errors import ProtocolError
from cavesim.core.wire.payloads.state_transfer import BlockQuery, BlockReply, BlockRequest

_STREAMS = ("particles", "emitters")

Ask = Callable[[BlockRequest], BlockReply | None]  # a BlockAsker of the confirmer


class NoConfirmation(Exception):
    """The confirmer did not answer: nothing can be committed in this resync."""


class Confirmation:
    """The confirmer `confirmer`'s word on the state of `frame` whose checksum is `digest`,
    asked through `ask`; each question is asked once (a state that several repliers sent is
    checked against the same answer). `seconds` and `questions` say what it cost."""

    def __init__(self, confirmer: str, ask: Ask, frame: int, digest: str) -> None:
        self.confirmer, self.ask, self.frame, self.digest = confirmer, ask, frame, digest
        self.questions = 0
        self.seconds = 0.0
        self._answers: dict[tuple, BlockReply] = {}

    def check(self, stream: int, indices: np.ndarray | None, received: bytes,
              state: tuple[int, int, int]) -> None:
        """ProtocolError (`unconfirmed`) unless the confirmer's digest of `stream`'s records
        `indices` (None: the whole stream) is `received`, the digest of the records the
        node is to commit, and its (seed, live particles, emitters) are `state`'s;
        NoConfirmation when it does not answer."""
        if indices is not None and not len(indices):
            raise ValueError("a confirmation names records, or None for the whole stream")
        reply = self._answer(stream, indices)
        what = _STREAMS[stream] if indices is None else \
            f"{len(indices)} {_STREAMS[stream]} records from {indices[0]}"
        held = (reply.seed, reply.particles, reply.emitters)
        if held != state:
            raise ProtocolError("unconfirmed", f"{self.confirmer} holds frame {self.frame} "
                                               f"with seed, particles and emitters {held}; "
                                               f"the state received has {state}")
        if reply.data != received:
            raise ProtocolError("unconfirmed", f"the {what} received are not those "
                                               f"{self.confirmer} holds of the state "
                                               f"{self.digest[:8]} (their SHA-256 digests "
                                               f"differ)")

    def said(self) -> str:
        return f"confirmed by {self.confirmer} ({self.questions} digest(s), " \
               f"{self.seconds:.3f} s)"

    def _answer(self, stream: int, indices: np.ndarray | None) -> BlockReply:
        key = (stream, None if indices is None else tuple(int(i) for i in indices))
        if key not in self._answers:
            started = time.monotonic()
            reply = self.ask(BlockRequest(self.frame, self.confirmer, self.digest,
                                          BlockQuery.DIGEST, stream, key[1] or ()))
            self.questions += 1
            self.seconds += time.monotonic() - started
            if reply is None:
                raise NoConfirmation(f"{self.confirmer}, named to confirm the state of frame "
                                     f"{self.frame}, did not answer")
            self._answers[key] = reply
        return self._answers[key]
