"""A node: one GL context, one ParticleSystem, stepped in lock-step with the cluster, and
the one wall or the several walls it draws from it (`NodeConfig.drawn`).

The context is opened on the EGL device the node was given (`--gpu`, default device 0),
or, with `--display`, is the context of its walls' window on its X display (`--preview`:
one window showing every wall). With `engine = "auto"` the node first times both engine
paths on its context and steps with the path the master's WELCOME names. Zenoh's threads
check every message before it reaches the main thread (`nodes/wall/inbox.py`); the main
thread, which owns the GL context, does all work, each part in a room of its own:
an info query -> answer with our GPU and a fresh nonce; the master's WELCOME naming that
nonce -> join its run (a node that held another run, whose master is gone, starts over
from the scene's start state; while that master is alive, the WELCOME is refused) and
report JOINED (`master_watch.py`); frame k -> step, checksum, counters, report k; a
repeated frame -> repeat the report; a frame ahead of us -> report BEHIND and wait for a
resync (`frame_step.py`); RESYNC -> load the named node's state of the named frame, by
delta or streamed snapshot, only whole and verified; a state or block query -> answer from
the state we hold (`state_service.py`); STOP -> leave cleanly. A displaying node also draws
every frame after its report and swaps when the master says SWAP (`nodes/wall/screen.py`);
closing its window makes it leave, which the master sees as a lost wall.

Nothing waits forever: a node no master has welcomed within `--master-wait` exits with an
error (naming a --key-file mismatch when it sees one); when the master's liveliness token
goes away, the node exits (`--on-master-loss exit`) or waits `--master-wait` for a new
master (`wait`); a master long silent counts as gone (`master_watch.py`).
"""
from __future__ import annotations

import dataclasses
import logging
import secrets
import time

import zenoh

from cavesim.core.cave.desktop import tiled_window
from cavesim.core.cave.geometry import Cave, Display, load_cave
from cavesim.core.drivers import driver_for
from cavesim.core.errors import ContextError
from cavesim.core.scene import Engine, load_scene
from cavesim.core.scene.digest import scene_digest
from cavesim.core.trajectories import TrajectoryRecording
from cavesim.core.wire import (
    BlockRequest,
    Command,
    ControlMessage,
    DisplayMessage,
    FrameMessage,
    ReportMessage,
    SessionKeys,
    StateRequest,
    TrackingMessage,
    encode,
)
from cavesim.core.wire.envelope import Message
from cavesim.core.wire.network import (
    lockstep_publisher,
    open_session,
)
from cavesim.core.wire.payloads.from_nodes import Phase
from cavesim.gpu.engine import FrameInput, ParticleSystem
from cavesim.gpu.gl.context import create_context, gpu_of
from cavesim.gpu.render.painter import WallPainter
from cavesim.gpu.render.unfold import slots_of
from cavesim.gpu.window import WallWindow, open_window
from cavesim.tools.bench.engine_probe import probe_engines
from nodes.faults import Fault
from nodes.lockstep import MASTER_LOSS_POLICIES, NODE_UP, RESYNC_MODES
from nodes.wall.frame_step import FrameStep
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
from nodes.wall.master_watch import MasterWatch
from nodes.wall.preview_controls import PreviewControls
from nodes.wall.screen import LiveDisplay, PreviewScreen, WallScreen, window_size
from nodes.wall.settings import NodeConfig
from nodes.wall.state_service import StateService

log = logging.getLogger("cavesim.node")
POLL = 0.02  # s between looks at a window's events when no message comes
IDLE = 1.0  # s between looks at the master's presence when nothing comes


class WallNode(MasterWatch, FrameStep, StateService):
    """The node's state machine; `run` is its loop."""

    def __init__(self, config: NodeConfig, session: zenoh.Session) -> None:
        if config.on_master_loss not in MASTER_LOSS_POLICIES:
            raise ValueError(f"on_master_loss must be one of {MASTER_LOSS_POLICIES}")
        if config.resync not in RESYNC_MODES:
            raise ValueError(f"resync must be one of {RESYNC_MODES}, got {config.resync!r}")
        if config.preview and config.credentials is not None and config.operator is None:
            raise ValueError("a preview in a session with keys needs an operator's key: the "
                             "master takes pause, reset and stop from an operator alone")
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

    def _publish(self, report: ReportMessage, keep: bool = True) -> None:
        """Send `report`; `keep`: it describes the state we hold (repeat it, serve it)."""
        if keep:
            self.last_report = report
        self.report_publisher.put(self._seal(report))

    def _seal(self, message: Message, run_id: int | None = None) -> bytes:
        if isinstance(message, StateRequest | BlockRequest):  # whose budget it spends there
            message = dataclasses.replace(message, asker=self.config.name)
        credentials = self.config.operator if isinstance(message, TrackingMessage) \
            else self.config.credentials  # the preview speaks as an operator, not as a wall
        return encode(message, self.config.session, credentials,
                      self.view.run_id or 0 if run_id is None else run_id)

    # -- the window ----------------------------------------------------------------------

    def _tend_window(self) -> None:
        """Between events: the window system's events; a closed window ends the node; the
        preview's input goes out as a tracker's would, signed as an operator."""
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


def main(config: NodeConfig) -> int:
    """Run one wall node until the master says STOP (or the process is told to end)."""
    with open_session(config.network) as session:
        node = WallNode(config, session)
        declarations = node.declare()
        gpu = node.gpu
        log.info("%s: %s %d (%s): %s, %s, OpenGL %s; engine path %s", config.name, NODE_UP,
                 gpu["device"], gpu["kind"], gpu["renderer"], gpu["vendor"], gpu["version"],
                 node.system.engine)
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
