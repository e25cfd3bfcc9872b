"""A wall node's state as a resync moves it (a part of `WallNode`, nodes/wall/process.py):
in, a RESYNC loads the named node's state of the named frame, first by delta
(`nodes/wall/delta.py`: only the records whose blocks differ), else by the full streamed
snapshot (`nodes/wall/snapshots.py`), and only whole, with the named checksum and confirmed
by the second wall the master named (`nodes/wall/confirmation.py`); out, the node answers a
resyncing node's state query and block questions (the master's forensics, a delta, a
confirmation) about the state it holds, and refuses one about another state.
"""

from __future__ import annotations

import logging
import time

import zenoh

from cavesim.core.errors import ProtocolError
from cavesim.core.frame_cost import NO_COST
from cavesim.core.trajectories import TrajectoryRecording
from cavesim.core.wire import (
    BlockRequest,
    ControlMessage,
    ReportMessage,
    SessionKeys,
    StateRequest,
    decode_envelope,
)
from cavesim.core.wire.envelope import Envelope
from cavesim.core.wire.payloads.from_nodes import Status
from cavesim.core.wire.rejects import RejectCounter
from cavesim.core.wire.replies import anyone_alive
from cavesim.core.wire.snapshot import transfer_seconds
from cavesim.gpu.engine import ParticleSystem
from nodes.blocks import BlockAsker, StreamDigests, serve_blocks
from nodes.lockstep import UNCONFIRMED
from nodes.wall.confirmation import Confirmation, NoConfirmation
from nodes.wall.delta import DeltaRefused, fetch_delta
from nodes.wall.inbox import NodeView
from nodes.wall.settings import NodeConfig
from nodes.wall.snapshots import SourceRefused, fetch_snapshot, send_snapshot

log = logging.getLogger("cavesim.node")
RESYNC_PAUSE = 0.25  # s between two state queries of one resync (the source rate-limits them)
SOURCE_WAIT = 1.0  # s a resync waits for the source's liveliness before asking again
DELTA_SECONDS = 5.0  # s for all of a delta's questions; then the full snapshot


class StateService:
    """Resyncs in, state and blocks out (see the module docstring). Of the node it uses the
    attributes below, `done`, `_fault`, `_seal`, `_publish` and `_sample` (`FrameStep`'s)."""

    config: NodeConfig
    system: ParticleSystem
    view: NodeView
    rejects: RejectCounter
    session: zenoh.Session
    keys: SessionKeys
    last_report: ReportMessage | None
    trajectories: TrajectoryRecording | None
    stream_digests: StreamDigests  # of the state it holds, for the resyncs it confirms

    def _resync(self, command: ControlMessage) -> None:
        """Load `command.source`'s state of `command.frame`, whose checksum the master named,
        confirmed by `command.confirmer` when it names one, and report RESYNCED; nothing is
        loaded unless the whole state arrives, has that checksum and is confirmed.

        A node that has just come back may not yet have its direct link to the source: a
        query then finds nobody at once. It asks again until the deadline (which scales with
        the largest state the scene holds), each time after a pause and after waiting (on
        liveliness, up to a second) for the source to be reachable. A forged stream that
        comes first costs no second query (`fetch_snapshot` then loads the next); when every
        stream of the state the source's key sent was refused, or the confirmer does not
        answer, the resync ends at once, and the master tries another source.
        """
        source, wall = command.source, self.config.name
        started = time.monotonic()
        failed_repliers: set[str] = set()
        confirmation = self._confirmation(command, started)
        try:
            if self.config.resync == "delta" and self._delta(command, failed_repliers, started,
                                                             confirmation):
                return
            if self._stream(command, failed_repliers, started, confirmation):
                return
        except (SourceRefused, NoConfirmation) as e:
            log.error("%s: no state of frame %d from %s: %s; keeping our state", wall,
                      command.frame, source, e)
        state = self.system.checksum()  # the master sees at once that the resync failed
        self._publish(ReportMessage(command.frame, wall, state.digest, state.particles,
                                    state.emitters, NO_COST, self.rejects.total, Status.RESYNCED,
                                    self._sample()), keep=False)

    def _stream(self, command: ControlMessage, failed: set[str], started: float,
                confirmation: Confirmation | None) -> bool:
        """Load the named state by streaming the full snapshot, asking again until the
        deadline; False (said in the log) when none came."""
        source = command.source
        deadline = started + transfer_seconds(self.system.capacity)
        while deadline > time.monotonic():
            request = StateRequest(command.frame, source, command.digest)  # a fresh nonce
            sealed = self._seal(request)
            received = [len(sealed)]
            header = fetch_snapshot(self.session, self.keys.state(source), self.system,
                                    sealed, self._open_reply, request, deadline,
                                    self.rejects, failed, confirmation, received.append)
            if header is not None:
                self._loaded(header.frame, source, f"{header.particles} particles in "
                             f"{header.chunks} chunks, {sum(received)} bytes",
                             time.monotonic() - started, confirmation)
                return True
            time.sleep(min(RESYNC_PAUSE, max(deadline - time.monotonic(), 0.0)))
            anyone_alive(self.session, self.keys.alive(source),
                         min(time.monotonic() + SOURCE_WAIT, deadline))
        log.error("%s: no verified snapshot of frame %d from %s within %.0f s",
                  self.config.name, command.frame, source, deadline - started)
        return False

    def _confirmation(self, command: ControlMessage, started: float) -> Confirmation | None:
        """The confirmer's word on the state (None where the master named nobody)."""
        if not command.confirmer:
            return None
        ask = BlockAsker(self.session, self.keys.blocks(command.confirmer), self._seal,
                         self._open_reply, self.rejects,
                         deadline=started + transfer_seconds(self.system.capacity))
        return Confirmation(command.confirmer, ask, command.frame, command.digest)

    def _delta(self, command: ControlMessage, failed: set[str], started: float,
               confirmation: Confirmation | None) -> bool:
        """Load the named state by fetching only the records whose blocks differ from the
        source's; False (said in the log) when the full snapshot must do it."""
        source = command.source
        ask = BlockAsker(self.session, self.keys.blocks(source), self._seal, self._open_reply,
                         self.rejects, failed, deadline=started + DELTA_SECONDS)
        try:
            delta = fetch_delta(self.system, ask, command.frame, source, command.digest,
                                confirmation)
        except DeltaRefused as e:
            if e.refusal is not None:
                self.rejects.reject(e.refusal, self.keys.blocks(source))
            if e.bad_data and ask.replier is not None:
                failed.add(ask.replier)
            log.warning("%s: no delta resync from %s (%s); streaming the full snapshot",
                        self.config.name, source, e)
            return False
        self._loaded(command.frame, source, f"by delta, {delta.records} records under "
                     f"{delta.blocks} differing block(s), {ask.bytes} bytes",
                     time.monotonic() - started, confirmation)
        return True

    def _open_reply(self, data: bytes) -> Envelope:
        """A reply to our snapshot or block query, checked: of our run (whose key signed it,
        the asker checks)."""
        envelope = decode_envelope(data, self.config.session, self.config.credentials)
        if envelope.run_id != self.view.run_id:
            raise ProtocolError("wrong-run", f"a reply of run {envelope.run_id:#018x}")
        return envelope

    def _loaded(self, frame: int, source: str, how: str, seconds: float,
                confirmation: Confirmation | None) -> None:
        self.view.done = frame
        self.stream_digests.forget()  # what it confirms now is the state just loaded
        if self.trajectories is not None and not self.trajectories.holds(
                self.system.read_particles()):
            log.error("%s: resynced to a state the trajectories did not follow: "
                      "trajectories.parquet is not written", self.config.name)
            self.trajectories.abort()
            self.trajectories = None
        state = self.system.checksum()
        self.system.keep_history(frame)
        log.info("%s: resynced to frame %d from %s: %s, %.2f s; %s", self.config.name, frame,
                 source, how, seconds, UNCONFIRMED if confirmation is None
                 else confirmation.said())
        self._publish(ReportMessage(frame, self.config.name, state.digest, state.particles,
                                    state.emitters, NO_COST, self.rejects.total, Status.RESYNCED,
                                    self._sample()))

    def _serve_blocks(self, query: zenoh.Query, request: BlockRequest) -> int:
        """Answer a question about the state we hold, if it is the one it names; the bytes
        sent."""
        held = self.last_report
        return serve_blocks(query, self.keys.blocks(self.config.name), self.system,
                            self.config.name,
                            None if held is None else (held.frame, held.digest), request,
                            self._seal, self.stream_digests)

    def _serve_state(self, query: zenoh.Query, request: StateRequest) -> int:
        """Stream our state to a resyncing node, if it is the one it asks for; the bytes
        sent."""
        held = self.last_report
        if self._fault("withhold", request.frame):  # the harness's: a forger's goes first
            log.info("%s: withholding the state of frame %d from %s (injected)",
                     self.config.name, request.frame, request.asker)
            query.drop()
            return 0
        if held is None or held.frame != request.frame or held.digest != request.digest:
            self.rejects.reject(ProtocolError("not-held", f"asked for the state of frame "
                                                          f"{request.frame} "
                                                          f"({request.digest[:8]}); holding "
                                                          f"frame {self.done}"),
                                self.keys.state(self.config.name))
            query.drop()
            return 0
        return send_snapshot(query, self.keys.state(self.config.name), self.system, self.done,
                             self._seal, self.config.chunk_particles)
