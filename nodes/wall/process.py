"""A node: one GL context, one ParticleSystem, stepped in lock-step with the cluster, and
the one wall or the several walls it draws from it (`NodeConfig.drawn`).

The context is opened on the EGL device the node was given (`--gpu`, default device 0),
or, with `--display`, is the context of its walls' window on its X display (`--preview`:
one window showing every wall). With `engine = "auto"` the node first times both engine
paths on its context and steps with the path the master's WELCOME names. Zenoh's threads
check every message before it reaches the main thread (`nodes/wall/inbox.py`); the main
thread, which owns the GL context, does all work:
an info query -> answer with our GPU and a fresh nonce; the master's WELCOME naming that
nonce -> join its run (a node that held another run, whose master is gone, starts over
from the scene's start state; while that master is alive, the WELCOME is refused) and
report JOINED; frame k -> step, checksum, report k; a repeated frame -> repeat
the report; a frame ahead of us -> report BEHIND and wait for a resync; RESYNC -> stream the
named node's snapshot of the named frame and checksum in, and load it only whole and
verified; a state query -> stream our snapshot out (nodes/wall/snapshots.py); STOP ->
leave cleanly. A displaying node also draws every frame after its report and swaps when
the master says SWAP (`nodes/wall/screen.py`); closing its window makes it leave, which
the master sees as a lost wall. A block query (the master's desync forensics, a resyncing
node's delta) is answered from the state the node holds (`nodes/blocks.py`); each
frame's fold-1 items go into a history ring on the GPU for them. A RESYNC first tries a
delta (`nodes/wall/delta.py`: only the records whose blocks differ) and falls back to
the full snapshot.

Nothing waits forever: a node no master has welcomed within `--master-wait` exits with an
error (naming a --key-file mismatch when it sees one); when the master's liveliness token
goes away, the node exits (`--on-master-loss exit`) or waits `--master-wait` for a new
master (`wait`); a master silent for MASTER_SILENCE x `--master-wait` counts as gone.
"""

from __future__ import annotations

import dataclasses
import logging
import secrets
import time
from dataclasses import dataclass
from pathlib import Path

import zenoh

from cavesim.core.cave.desktop import tiled_window
from cavesim.core.cave.geometry import Cave, Display, load_cave
from cavesim.core.counters import entries
from cavesim.core.digest.shape import PARTICLES
from cavesim.core.drift import DriftSample
from cavesim.core.drivers import driver_for
from cavesim.core.errors import ClusterError, ContextError, ProtocolError, TrajectoryError
from cavesim.core.frame_cost import NO_COST
from cavesim.core.record_diff import field_bit
from cavesim.core.records import PARTICLE_DTYPE
from cavesim.core.scene import Engine, load_scene
from cavesim.core.scene.digest import scene_digest
from cavesim.core.scene_frame import SceneFrame
from cavesim.core.trajectories import TrajectoryRecording, TrajectoryRequest
from cavesim.core.wire import (
    BlockRequest,
    Command,
    ControlMessage,
    Credentials,
    DisplayMessage,
    FrameMessage,
    InfoMessage,
    ReportMessage,
    SessionKeys,
    StateRequest,
    decode_envelope,
    encode,
)
from cavesim.core.wire.envelope import Envelope, Message
from cavesim.core.wire.network import (
    NetworkSettings,
    lockstep_publisher,
    open_session,
    zenoh_message,
)
from cavesim.core.wire.payloads.from_nodes import Phase, Status
from cavesim.core.wire.replies import anyone_alive
from cavesim.core.wire.snapshot import CHUNK_PARTICLES, transfer_seconds
from cavesim.gpu.engine import FrameInput, ParticleSystem
from cavesim.gpu.gl.context import create_context, gpu_of
from cavesim.gpu.render.painter import WallPainter
from cavesim.gpu.render.unfold import slots_of
from cavesim.gpu.window import WallWindow, open_window
from cavesim.tools.bench.engine_probe import probe_engines
from nodes.blocks import BlockAsker, serve_blocks
from nodes.faults import Fault, bitflip_target, inflated
from nodes.lockstep import MASTER_GONE, MASTER_LOSS_POLICIES, RESYNC_MODES
from nodes.wall.delta import DeltaRefused, fetch_delta
from nodes.wall.drift_sample import DRIFT_FAULTS, read_drift_sample
from nodes.wall.frame_timer import FrameTimer
from nodes.wall.inbox import (
    BlocksQuery,
    FromMaster,
    InfoQuery,
    MasterPresence,
    NodeInbox,
    NodeView,
    StateQuery,
)
from nodes.wall.preview_controls import PreviewControls
from nodes.wall.screen import LiveDisplay, PreviewScreen, WallScreen, window_size
from nodes.wall.snapshots import fetch_snapshot, send_snapshot

log = logging.getLogger("cavesim.node")
SLOW_DELAY = 1.5  # s a `slow` fault holds a report back (tests use a shorter barrier)
POLL = 0.02  # s between looks at a window's events when no message comes
IDLE = 1.0  # s between looks at the master's presence when nothing comes

MASTER_SILENCE = 10  # x --master-wait: a master this long silent counts as gone
BEHIND_EVERY = 1.0  # s between two BEHIND reports
RESYNC_PAUSE = 0.25  # s between two state queries of one resync (the source rate-limits them)
SOURCE_WAIT = 1.0  # s a resync waits for the source's liveliness before asking again
DELTA_SECONDS = 5.0  # s for all of a delta's questions; then the full snapshot


@dataclass(frozen=True)
class NodeConfig:
    name: str  # the node's, in the run: its wall's, or a node the CAVE file gives walls
    scene: Path
    session: str = "default"
    network: NetworkSettings = NetworkSettings()
    credentials: Credentials | None = None  # wall-NAME.key: signs as this node, checks the master's
    faults: tuple[Fault, ...] = ()
    slow_delay: float = SLOW_DELAY
    cave: Path | None = None  # draw this node's walls of this CAVE ...
    walls: tuple[str, ...] = ()  # ... these (default: the one called `name`) ...
    render_every: int = 0  # ... every K frames (0: never) ...
    images: Path | None = None  # ... into images/<wall>/frame_<k>.png
    stereo: bool = False
    chunk_particles: int = CHUNK_PARTICLES  # particles per reply of a snapshot we send
    gpu: int | None = None  # EGL device index (None: the default device, 0)
    engine: Engine | None = None  # the particle engine path (None: the scene's)
    display: bool = False  # show the wall live in a window, as the CAVE's [wall.display] says
    preview: bool = False  # show every wall of the CAVE unfolded in one desktop window
    preview_scale: float = 0.5  # of each wall's resolution, in the preview
    on_master_loss: str = "wait"  # or "exit" when the master's liveliness token goes away
    master_wait: float = 60.0  # s to wait for a master's WELCOME, or for a new master
    drift_sample: int = 0  # mixed-hardware mode: records sampled into each report (0: none)
    resync: str = "delta"  # how a RESYNC loads the named state: one of RESYNC_MODES
    trajectories: TrajectoryRequest | None = None  # write trajectories.parquet ...
    trajectory_folder: Path | None = None  # ... into this folder

    @property
    def drawn(self) -> tuple[str, ...]:
        """The walls this node draws, when it draws."""
        return self.walls or (self.name,)


class WallNode:
    """The node's state machine; `run` is its loop."""

    def __init__(self, config: NodeConfig, session: zenoh.Session) -> None:
        if config.on_master_loss not in MASTER_LOSS_POLICIES:
            raise ValueError(f"on_master_loss must be one of {MASTER_LOSS_POLICIES}")
        if config.resync not in RESYNC_MODES:
            raise ValueError(f"resync must be one of {RESYNC_MODES}, got {config.resync!r}")
        self.config = config
        self.keys = SessionKeys(config.session)
        self.fired: set[Fault] = set()  # injected faults done
        scene = load_scene(config.scene)
        self.scene_digest = scene_digest(scene)  # of the file's scene: a run must be of it
        if config.engine is not None:
            scene = dataclasses.replace(scene, engine=config.engine)
        if self._fault("seed"):
            scene = dataclasses.replace(scene, seed=scene.seed + 1)
        self.seed = scene.seed  # the start state's: a new run starts from it
        self.session = session
        cave = load_cave(config.cave) if config.cave is not None else None
        window = open_node_window(config, cave)
        self.ctx = window.ctx if window is not None else create_context(device=config.gpu)
        self.gpu = gpu_of(self.ctx)
        self.engine_probed = scene.engine is Engine.AUTO  # then the run's path is the master's
        if self.engine_probed:
            probe = probe_engines(self.ctx, scene)
            log.info("%s: %s", config.name, probe.line())
            scene = dataclasses.replace(scene, engine=probe.faster)
        self.system = ParticleSystem(self.ctx, scene)
        self.driver = driver_for(scene)
        self.live = None if window is None else LiveDisplay(
            node_screen(config, cave, window, self.system), self._display)
        self.controls = PreviewControls(window.window) if config.preview else None
        self.painter = _painter(config, cave, self.ctx, self.system) \
            if config.render_every and window is None else None
        self.view = NodeView(config.name, secrets.randbits(64))
        self.inbox = NodeInbox(config.session, config.credentials, self.view)
        self.rejects = self.inbox.rejects
        self.last_report: ReportMessage | None = None
        self.previous_inputs: FrameInput | None = None
        self.timer = FrameTimer(self.system.fence, self.system.timers)  # for our reports
        self.started = self.heard = time.monotonic()  # from the master of our run
        self.master_gone_at: float | None = None
        self.behind_said = 0.0
        self.running = True
        self.trajectories = None if config.trajectories is None else TrajectoryRecording(
            config.trajectory_folder, scene, config.trajectories, self.scene_digest)

    @property
    def done(self) -> int:
        """The last frame whose state we hold."""
        return self.view.done

    def _fault(self, kind: str, frame: int | None = None) -> bool:
        """Whether an injected fault of `kind` is due (at `frame`); each fires once, so a
        frame number that comes again (a new master's run) does not repeat it."""
        due = next((f for f in self.config.faults if f.kind == kind and f not in self.fired
                    and (frame is None or f.frame == frame)), None)
        if due is not None:
            self.fired.add(due)
        return due is not None

    def declare(self) -> list:
        """Subscribe and answer queries, then announce ourselves (liveliness last)."""
        keys, wall = self.keys, self.config.name
        self.report_publisher = lockstep_publisher(self.session, keys.report(wall))
        self.display_publisher = lockstep_publisher(self.session, keys.display(wall))
        return [*self.inbox.declare(self.session, keys),
                self.session.liveliness().declare_token(keys.alive(wall))]

    def run(self) -> None:
        while self.running:
            event = self.inbox.get(POLL if self.live is not None else IDLE)
            self._tend_window()
            match event:
                case FromMaster(message, run_id):
                    self.heard = time.monotonic()
                    self._from_master(message, run_id)
                case StateQuery(query, request):
                    self.inbox.spent(event, self._serve_state(query, request))
                case BlocksQuery(query, request):
                    self.inbox.spent(event, self._serve_blocks(query, request))
                case InfoQuery(query, run_id):
                    self.inbox.spent(event, self._answer_info(query, run_id))
                case MasterPresence(run_id, up):
                    self._master_presence(run_id, up)
            self._check_master()

    def _from_master(self, message: FrameMessage | ControlMessage, run_id: int) -> None:
        if isinstance(message, FrameMessage):
            self._on_frame(message)
        elif message.command is Command.WELCOME:
            # the inbox checked it, but a second master's WELCOME may have been queued
            # before the first one's was joined
            if not self.inbox.refuses_hop(run_id, self.keys.control):
                self._join(run_id, message.digest, message.engine)
        elif message.command is Command.STOP:
            self.running = False
        elif message.command is Command.SWAP and self.live is not None:
            self.live.swap(message.frame)
        elif message.command is Command.RESYNC:
            self._resync(message)

    # -- joining a run, and the master's presence ----------------------------------------

    def _answer_info(self, query: zenoh.Query, run_id: int) -> int:
        """Our GPU, whether we are swap-locked, and the nonce a WELCOME must name; the bytes
        sent."""
        swap_locked = self.live is not None and self.live.screen.swap_locked
        message = self._seal(InfoMessage.of_gpu(self.done, self.config.name, self.gpu,
                                                swap_locked, self.view.nonce,
                                                self.scene_digest, self.system.engine,
                                                self.engine_probed), run_id)
        try:
            query.reply(self.keys.info(self.config.name), message)
        except zenoh.ZError as e:  # the master asking went away
            log.info("%s: an info reply failed: %s", self.config.name, zenoh_message(e))
            return 0
        finally:
            query.drop()
        return len(message)

    def _join(self, run_id: int, scene: str, engine: Engine | None) -> None:
        """The master's WELCOME named our nonce: join its run, from the scene's start state
        if we held another run's, stepping with the run's engine path if we probed ours; a
        run of another scene ends the node (ClusterError)."""
        if scene != self.scene_digest:
            raise ClusterError(f"node {self.config.name}: the master's run {run_id:016x} is "
                               f"of scene {scene or 'none'}, this node's --scene "
                               f"{self.config.scene} is {self.scene_digest}: give every "
                               f"host the same scene file")
        previous = self.view.run_id
        if previous is not None and previous != run_id:
            log.warning("%s: a new master's run %016x replaces run %016x: starting over "
                        "from the scene's start state", self.config.name, run_id, previous)
            self._start_over()
        if previous != run_id:
            self.view.heard = 0
        if engine is not None and self.engine_probed and engine is not self.system.engine:
            log.info("%s: the run steps with %s: switching from %s", self.config.name, engine,
                     self.system.engine)
            self.system.use_engine(engine)
        self.view.run_id, self.view.nonce = run_id, secrets.randbits(64)  # nonce used up
        self.master_gone_at = None
        state = self.system.checksum()
        log.info("%s: joined run %016x at frame %d", self.config.name, run_id, self.done)
        self._publish(ReportMessage(self.done, self.config.name, state.digest, state.particles,
                                    state.emitters, NO_COST, self.rejects.total, Status.JOINED))

    def _start_over(self) -> None:
        self.system.restart(self.seed)
        if self.trajectories is not None:
            self.trajectories.restart()
        self.view.done = 0
        self.last_report = self.previous_inputs = None
        if self.live is not None:
            self.live.pending = None

    def _master_presence(self, run_id: int, up: bool) -> None:
        """Only the master of our run counts: another one's token does not hold us."""
        if run_id != self.view.run_id:
            return
        if up:
            self.master_gone_at = None
        elif self.master_gone_at is None:
            self.master_gone_at = time.monotonic()
            if self.config.on_master_loss == "wait":
                log.warning("%s: %s (run %016x); waiting up to %g s for a new master "
                            "(--on-master-loss wait)", self.config.name, MASTER_GONE,
                            self.view.run_id, self.config.master_wait)

    def _check_master(self) -> None:
        """End the node (ClusterError, one line) when no master is there to follow."""
        now, wall, wait = time.monotonic(), self.config.name, self.config.master_wait
        if self.view.run_id is None:
            if now - self.started > wait:
                hint = self.inbox.master_hint() or ("is the master running, with --session "
                                                    f"{self.config.session}?")
                raise ClusterError(f"node {wall}: no master welcomed it within {wait:g} s "
                                   f"(--master-wait): {hint}")
            return
        if self.master_gone_at is not None and self.config.on_master_loss == "exit":
            raise ClusterError(f"node {wall}: the master of run {self.view.run_id:016x} is "
                               f"gone (its liveliness token went away); leaving "
                               f"(--on-master-loss exit)")
        if self.master_gone_at is not None and now - self.master_gone_at > wait:
            raise ClusterError(f"node {wall}: the master of run {self.view.run_id:016x} is "
                               f"gone and no new master came within {wait:g} s "
                               f"(--master-wait, --on-master-loss wait)")
        if now - self.heard > MASTER_SILENCE * wait:
            raise ClusterError(f"node {wall}: nothing from the master of run "
                               f"{self.view.run_id:016x} for {now - self.heard:.0f} s "
                               f"({MASTER_SILENCE} x --master-wait); leaving")

    # -- frames --------------------------------------------------------------------------

    def _on_frame(self, message: FrameMessage) -> None:
        k = message.frame
        if k == self.done and self.last_report is not None:
            self._publish(dataclasses.replace(self.last_report, status=Status.REPEATED))
        elif k == self.done + 1:
            if self._fault("drop", k):  # lose this copy; the master's retransmit gets through
                log.warning("%s: fault: dropped frame %d", self.config.name, k)
                return
            self.timer.arrived()
            try:
                scene = self.driver.decode(message.params)
            except ProtocolError as e:
                self.rejects.reject(e, f"frame {k}")
                return
            self.timer.lap("decode")
            self.timer.arm_gpu(k)
            self._step(k, message.inputs, scene, message.reset)
            if self.live is not None:
                self.live.show(k, message, scene)
                self.timer.rendered()
            elif self.painter is not None and k % self.config.render_every == 0:
                self.painter.paint(k, message, scene)
                self.timer.rendered()
        elif k > self.done + 1:
            self._behind(k)

    def _behind(self, k: int) -> None:
        """Frame k is ahead of ours: ask the master for a resync (at most every second)."""
        now = time.monotonic()
        if now - self.behind_said < BEHIND_EVERY:
            return
        self.behind_said = now
        log.info("%s: frame %d is ahead of our frame %d; asking for a resync",
                 self.config.name, k, self.done)
        state = self.system.checksum()
        self._publish(ReportMessage(self.done, self.config.name, state.digest, state.particles,
                                    state.emitters, NO_COST, self.rejects.total, Status.BEHIND),
                      keep=False)

    def _step(self, k: int, inputs: FrameInput, scene: SceneFrame, reset: bool) -> None:
        if reset:  # the master's reset: the scene's start state, then this frame's step
            self.system.restart(self.seed)
            if self.trajectories is not None:
                self.trajectories.restart()
        used = inputs
        if self._fault("stale", k) and self.previous_inputs is not None:
            used = FrameInput(inputs.dt, self.previous_inputs.random_transform)
        self.system.step(used, scene)
        self.timer.lap("step")
        if self._fault("bitflip", k) and self.system.live_count:
            self._flip_one_bit()
        for kind, perturb in DRIFT_FAULTS.items():
            if self._fault(kind, k):
                perturb(self.system)
                log.warning("%s: fault: %s at frame %d", self.config.name, kind, k)
        self.previous_inputs = inputs
        self.view.done = k
        state = self.system.checksum()
        self.timer.lap("checksum")
        self.timer.gpu_passes()
        self.system.keep_history(k)
        self.timer.lap("history")
        if self._fault("slow", k):
            time.sleep(self.config.slow_delay)
        counted = entries(self.system.counters())  # read after the checksum's wait
        if self._fault("inflate", k):
            counted = inflated(counted)
            log.warning("%s: fault: reported inflated counters at frame %d", self.config.name, k)
        self._publish(ReportMessage(k, self.config.name, state.digest, state.particles,
                                    state.emitters, self.timer.cost_us(), self.rejects.total,
                                    sample=self._sample(), counters=counted))
        self.timer.reported()
        if self.trajectories is not None:  # after the report: the barrier does not wait on it
            self._follow_trajectories(k, used.dt)

    def _follow_trajectories(self, k: int, dt: float) -> None:
        """Follow frame k's step. A lost stream drops the file, not the run; a write that
        fails (OutputError) ends the node, and so the run, as every failed write does."""
        try:
            self.trajectories.after_step(k, dt, self.system)
        except TrajectoryError as e:
            log.error("%s: frame %d: %s; trajectories.parquet is not written",
                      self.config.name, k, e)
            self.trajectories = None

    def finish_trajectories(self) -> None:
        """The run is over (STOP): give trajectories.parquet its footer and its name."""
        if self.trajectories is not None:
            path = self.trajectories.finish()
            log.info("%s: wrote %s (%d rows)", self.config.name, path,
                     self.trajectories.recorder.rows)

    def _flip_one_bit(self) -> None:
        """Flip the bit `bitflip_target` names, in that one record (patched on the GPU)."""
        target = bitflip_target(self.system.live_count)
        record = bytearray(self.system.read_records(PARTICLES, [target.particle]))
        record[target.word * 4 + target.bit // 8] ^= 1 << target.bit % 8
        self.system.begin_patch()
        self.system.write_particle_chunk(target.particle, bytes(record))
        self.system.commit_load()
        field, bit = field_bit(PARTICLE_DTYPE, target.word, target.bit)
        log.warning("%s: fault: flipped bit %d of particle %d's %s", self.config.name, bit,
                    target.particle, field.name)

    def _sample(self) -> DriftSample | None:
        """The mixed-hardware mode's drift sample of the state we hold (else None)."""
        if not self.config.drift_sample:
            return None
        return read_drift_sample(self.system, self.config.drift_sample)

    def _publish(self, report: ReportMessage, keep: bool = True) -> None:
        """Send `report`; `keep`: it describes the state we hold (repeat it, serve it)."""
        if keep:
            self.last_report = report
        self.report_publisher.put(self._seal(report))

    def _seal(self, message: Message, run_id: int | None = None) -> bytes:
        if isinstance(message, StateRequest | BlockRequest):  # whose budget it spends there
            message = dataclasses.replace(message, asker=self.config.name)
        return encode(message, self.config.session, self.config.credentials,
                      self.view.run_id or 0 if run_id is None else run_id)

    # -- the window ----------------------------------------------------------------------

    def _tend_window(self) -> None:
        """Between events: the window system's events; a closed window ends the node; the
        preview's input goes out as a tracker's would."""
        if self.live is None:
            return
        if self.live.closed():
            log.info("%s: the window was closed; leaving", self.config.name)
            self.running = False
        if self.controls is not None and (tracked := self.controls.advance()) is not None:
            self.session.put(self.keys.tracking, self._seal(tracked))

    def _display(self, k: int, phase: Phase, time_ns: int) -> None:
        self.display_publisher.put(self._seal(DisplayMessage(k, self.config.name, phase,
                                                             time_ns)))

    # -- snapshots ---------------------------------------------------------------------------

    def _resync(self, command: ControlMessage) -> None:
        """Stream in `command.source`'s snapshot of `command.frame`, whose checksum the master
        named, and report RESYNCED; nothing is loaded unless the whole state arrives and has
        that checksum.

        A node that has just come back may not yet have its direct link to the source: a
        query then finds nobody at once; a forged reply may come first. It asks again until
        the deadline (which scales with the largest state the scene holds), each time after
        a pause and after waiting (on liveliness, up to a second) for the source to be
        reachable.
        """
        source, wall = command.source, self.config.name
        started = time.monotonic()
        failed_repliers: set[str] = set()
        if self.config.resync == "delta" and self._delta(command, failed_repliers, started):
            return
        deadline = started + transfer_seconds(self.system.capacity)
        while deadline > time.monotonic():
            request = StateRequest(command.frame, source, command.digest)  # a fresh nonce
            sealed = self._seal(request)
            received = [len(sealed)]
            header = fetch_snapshot(self.session, self.keys.state(source), self.system,
                                    sealed, self._open_reply, request, deadline,
                                    self.rejects, failed_repliers, received.append)
            if header is not None:
                self._loaded(header.frame, source, f"{header.particles} particles in "
                             f"{header.chunks} chunks, {sum(received)} bytes",
                             time.monotonic() - started)
                return
            time.sleep(min(RESYNC_PAUSE, max(deadline - time.monotonic(), 0.0)))
            anyone_alive(self.session, self.keys.alive(source),
                         min(time.monotonic() + SOURCE_WAIT, deadline))
        log.error("%s: no verified snapshot of frame %d from %s within %.0f s; keeping our "
                  "state", wall, command.frame, source, deadline - started)
        state = self.system.checksum()  # the master sees at once that the resync failed
        self._publish(ReportMessage(command.frame, wall, state.digest, state.particles,
                                    state.emitters, NO_COST, self.rejects.total, Status.RESYNCED,
                                    self._sample()), keep=False)

    def _delta(self, command: ControlMessage, failed: set[str], started: float) -> bool:
        """Load the named state by fetching only the records whose blocks differ from the
        source's; False (said in the log) when the full snapshot must do it."""
        source = command.source
        ask = BlockAsker(self.session, self.keys.blocks(source), self._seal, self._open_reply,
                         self.rejects, failed, deadline=started + DELTA_SECONDS)
        try:
            delta = fetch_delta(self.system, ask, command.frame, source, command.digest)
        except DeltaRefused as e:
            if e.bad_data and ask.replier is not None:
                failed.add(ask.replier)
            log.warning("%s: no delta resync from %s (%s); streaming the full snapshot",
                        self.config.name, source, e)
            return False
        self._loaded(command.frame, source, f"by delta, {delta.records} records under "
                     f"{delta.blocks} differing block(s), {ask.bytes} bytes",
                     time.monotonic() - started)
        return True

    def _open_reply(self, data: bytes) -> Envelope:
        """A reply to our snapshot or block query, checked: of our run (whose key signed it,
        the asker checks)."""
        envelope = decode_envelope(data, self.config.session, self.config.credentials)
        if envelope.run_id != self.view.run_id:
            raise ProtocolError("wrong-run", f"a reply of run {envelope.run_id:#018x}")
        return envelope

    def _loaded(self, frame: int, source: str, how: str, seconds: float) -> None:
        self.view.done = frame
        if self.trajectories is not None and not self.trajectories.holds(
                self.system.read_particles()):
            log.error("%s: resynced to a state the trajectories did not follow: "
                      "trajectories.parquet is not written", self.config.name)
            self.trajectories.abort()
            self.trajectories = None
        state = self.system.checksum()
        self.system.keep_history(frame)
        log.info("%s: resynced to frame %d from %s: %s, %.2f s", self.config.name, frame,
                 source, how, seconds)
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
                            self._seal)

    def _serve_state(self, query: zenoh.Query, request: StateRequest) -> int:
        """Stream our state to a resyncing node, if it is the one it asks for; the bytes
        sent."""
        held = self.last_report
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



def main(config: NodeConfig) -> int:
    """Run one wall node until the master says STOP (or the process is told to end)."""
    with open_session(config.network) as session:
        node = WallNode(config, session)
        declarations = node.declare()
        gpu = node.gpu
        log.info("%s: up on EGL device %d (%s): %s, %s, OpenGL %s; engine path %s",
                 config.name, gpu["device"], gpu["kind"], gpu["renderer"], gpu["vendor"],
                 gpu["version"], node.system.engine)
        try:
            node.run()
            node.finish_trajectories()
        except KeyboardInterrupt:
            log.info("%s: interrupted", config.name)
        finally:
            if node.trajectories is not None:
                node.trajectories.abort()  # a file not finished is not left
            for declaration in reversed(declarations):
                declaration.undeclare()
            if node.live is not None:
                node.live.close()
    return 0


def open_node_window(config: NodeConfig, cave: Cave | None) -> WallWindow | None:
    """The node's window (None for a headless node): its walls', side by side, as the
    first one's [wall.display] says (a `window` there gives where; its size is theirs;
    without a window, monitor or fullscreen, beside the windows of the walls before them,
    `tiled_window`); or the preview's."""
    if not (config.display or config.preview):
        return None
    if cave is None:
        raise ContextError("a window needs the CAVE: which walls to draw and how to show them",
                           "give --cave FILE with --display or --preview")
    title = window_title(config)
    if config.preview:
        size = slots_of(cave.scaled(config.preview_scale))[1]
        return open_window(Display(vsync=False, swap_lock=False), size, title)
    walls = tuple(cave.wall(w) for w in config.drawn)
    display, size = walls[0].display, window_size(walls)
    if display.window is None and not display.fullscreen and display.monitor is None:
        display = dataclasses.replace(display, window=tiled_window(cave, config.drawn))
    elif len(walls) > 1 and display.window is not None:
        display = dataclasses.replace(display, window=(*display.window[:2], *size))
    return open_window(display, size, title)


def _painter(config: NodeConfig, cave: Cave | None, ctx,
             system: ParticleSystem) -> WallPainter:
    if cave is None or config.images is None:
        raise ValueError("rendering needs both a CAVE file (--cave) and an image folder "
                         "(--images)")
    return WallPainter(ctx, system, cave, config.drawn, config.images, config.stereo)


def window_title(config: NodeConfig) -> str:
    return f"cavesim {config.name}"


def node_screen(config: NodeConfig, cave: Cave, window: WallWindow,
                system: ParticleSystem) -> WallScreen | PreviewScreen:
    if config.preview:
        return PreviewScreen(window, system, cave, config.preview_scale, window_title(config))
    return WallScreen(window, system, tuple(cave.wall(w) for w in config.drawn),
                      cave.eye_separation, config.images, config.render_every)
