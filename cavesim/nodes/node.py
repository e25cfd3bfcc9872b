"""A wall node: one GL context, one ParticleSystem, stepped in lock-step with the cluster.

The context is opened on the EGL device the node was given (`--gpu`, default device 0),
or, with `--display`, is the context of the wall's window on its X display (`--preview`:
one window showing every wall). Zenoh callbacks only enqueue; the main thread, which owns
the GL context, does all work:
frame k -> step, checksum, report k; a repeated frame -> repeat the report; a frame
ahead of us -> wait for a resync; RESYNC -> stream a healthy node's snapshot in and load
it; a state query -> stream our snapshot out (cavesim/nodes/snapshots.py); an info query ->
answer with our GPU; STOP -> leave cleanly. A displaying node also draws every frame after
its report and swaps when the master says SWAP (`cavesim/nodes/screen.py`); closing its
window makes it leave, which the master sees as a lost wall.
"""

from __future__ import annotations

import dataclasses
import logging
import queue
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import zenoh

from cavesim.core.cave.geometry import Cave, Display, load_cave
from cavesim.core.drivers import driver_for
from cavesim.core.errors import ContextError, ProtocolError
from cavesim.core.scene import load_scene
from cavesim.core.scene_frame import SceneFrame
from cavesim.core.wire import (
    Command,
    ControlMessage,
    DisplayMessage,
    FrameMessage,
    InfoMessage,
    ReportMessage,
    SessionKeys,
    decode,
    encode,
)
from cavesim.core.wire.messages import Message, Phase, Status
from cavesim.core.wire.network import NetworkConfig, lockstep_publisher, open_session
from cavesim.core.wire.rejects import RejectCounter
from cavesim.core.wire.snapshot import CHUNK_PARTICLES, transfer_seconds
from cavesim.gpu.engine import FrameInput, ParticleSystem
from cavesim.gpu.gl.context import create_context, gpu_of
from cavesim.gpu.render.unfold import slots_of
from cavesim.gpu.window import WallWindow, open_window
from cavesim.nodes.faults import Fault
from cavesim.nodes.painter import WallPainter
from cavesim.nodes.preview_controls import PreviewControls
from cavesim.nodes.screen import LiveDisplay, PreviewScreen, WallScreen, scaled
from cavesim.nodes.snapshots import fetch_snapshot, send_snapshot

log = logging.getLogger("cavesim.node")
SLOW_DELAY = 1.5  # s a `slow` fault holds a report back (tests use a shorter barrier)
POLL = 0.02  # s between looks at a window's events when no message comes


@dataclass(frozen=True)
class NodeConfig:
    wall: str
    scene: Path
    session: str = "default"
    network: NetworkConfig = NetworkConfig()
    key: bytes | None = None
    faults: tuple[Fault, ...] = ()
    slow_delay: float = SLOW_DELAY
    cave: Path | None = None  # draw this node's wall of this CAVE ...
    render_every: int = 0  # ... every K frames (0: never) ...
    images: Path | None = None  # ... into images/<wall>/frame_<k>.png
    stereo: bool = False
    chunk_particles: int = CHUNK_PARTICLES  # particles per reply of a snapshot we send
    gpu: int | None = None  # EGL device index (None: the default device, 0)
    display: bool = False  # show the wall live in a window, as the CAVE's [wall.display] says
    preview: bool = False  # show every wall of the CAVE unfolded in one desktop window
    preview_scale: float = 0.5  # of each wall's resolution, in the preview


class WallNode:
    """The node's state machine; `run` is its loop."""

    def __init__(self, config: NodeConfig, session: zenoh.Session) -> None:
        self.config = config
        self.keys = SessionKeys(config.session)
        scene = load_scene(config.scene)
        if self._fault("seed"):
            scene = dataclasses.replace(scene, seed=scene.seed + 1)
        self.session = session
        cave = load_cave(config.cave) if config.cave is not None else None
        window = open_node_window(config, cave)
        self.ctx = window.ctx if window is not None else create_context(device=config.gpu)
        self.gpu = gpu_of(self.ctx)
        self.system = ParticleSystem(self.ctx, scene)
        self.driver = driver_for(scene)
        self.live = None if window is None else LiveDisplay(
            node_screen(config, cave, window, self.system), self._display)
        self.controls = PreviewControls(window.window) if config.preview else None
        self.painter = WallPainter(config, self.ctx, self.system) \
            if config.render_every and window is None else None
        self.rejects = RejectCounter(f"node {config.wall}")
        self.done = 0  # last frame whose state we hold
        self.last_report: ReportMessage | None = None
        self.previous_inputs: FrameInput | None = None
        self.dropped: set[int] = set()
        self.events: queue.Queue = queue.Queue()
        self.running = True

    def _fault(self, kind: str, frame: int | None = None) -> bool:
        return any(f.kind == kind and (frame is None or f.frame == frame)
                   for f in self.config.faults)

    def declare(self) -> list:
        """Subscribe, answer state queries, then announce ourselves (liveliness last)."""
        put = self.events.put
        keys, wall = self.keys, self.config.wall
        self.report_publisher = lockstep_publisher(self.session, keys.report(wall))
        self.display_publisher = lockstep_publisher(self.session, keys.display(wall))
        return [
            self.session.declare_subscriber(keys.frame, lambda s: put(("frame", s))),
            self.session.declare_subscriber(keys.control, lambda s: put(("control", s))),
            self.session.declare_queryable(keys.state(wall), lambda q: put(("query", q))),
            self.session.declare_queryable(keys.info(wall), lambda q: put(("info", q))),
            self.session.liveliness().declare_token(keys.alive(wall)),
        ]

    def run(self) -> None:
        while self.running:
            try:
                kind, item = self.events.get(timeout=None if self.live is None else POLL)
            except queue.Empty:
                self._tend_window()
                continue
            self._tend_window()
            if kind in ("query", "info"):
                self._answer(kind, item)
                continue
            try:
                message = self._unseal(item.payload.to_bytes())
            except ProtocolError as e:
                self.rejects.reject(e, str(item.key_expr))
                continue
            expected = FrameMessage if kind == "frame" else ControlMessage
            if not isinstance(message, expected):
                self.rejects.reject(ProtocolError("unexpected", f"a {type(message).__name__} "
                                                  f"on the {kind} key"), str(item.key_expr))
            elif kind == "frame":
                self._on_frame(message)
            else:
                self._on_control(message)

    # -- frames --------------------------------------------------------------------------

    def _on_frame(self, message: FrameMessage) -> None:
        k = message.frame
        if k == self.done and self.last_report is not None:
            self._publish(dataclasses.replace(self.last_report, status=Status.REPEATED))
        elif k == self.done + 1:
            if self._fault("drop", k) and k not in self.dropped:
                self.dropped.add(k)  # lose this copy; the master's retransmit gets through
                log.warning("%s: fault: dropped frame %d", self.config.wall, k)
                return
            try:
                scene = self.driver.decode(message.params)
            except ProtocolError as e:
                self.rejects.reject(e, f"frame {k}")
                return
            self._step(k, message.inputs, scene)
            if self.live is not None:
                self.live.show(k, message, scene)
            elif self.painter is not None and k % self.config.render_every == 0:
                self.painter.paint(k, message, scene)
        elif k > self.done + 1:
            log.info("%s: frame %d is ahead of our frame %d; waiting for a resync",
                     self.config.wall, k, self.done)

    def _step(self, k: int, inputs: FrameInput, scene: SceneFrame) -> None:
        used = inputs
        if self._fault("stale", k) and self.previous_inputs is not None:
            used = FrameInput(inputs.dt, self.previous_inputs.random_transform)
        started = time.perf_counter()
        self.system.step(used, scene)
        stepped = time.perf_counter()
        if self._fault("bitflip", k) and self.system.live_count:
            self._flip_one_bit()
        self.previous_inputs = inputs
        self.done = k
        state = self.system.checksum()
        finished = time.perf_counter()
        if self._fault("slow", k):
            time.sleep(self.config.slow_delay)
        self._publish(ReportMessage(k, self.config.wall, state.digest, state.particles,
                                    state.emitters, int((stepped - started) * 1e6),
                                    int((finished - stepped) * 1e6), self.rejects.total))

    def _flip_one_bit(self) -> None:
        particles = self.system.read_particles()
        words = particles.view(np.uint32)
        words[len(words) // 2] ^= np.uint32(1 << 20)
        self.system.write_particles(particles)
        log.warning("%s: fault: flipped one bit of the particle buffer", self.config.wall)

    def _publish(self, report: ReportMessage) -> None:
        self.last_report = report
        self.report_publisher.put(self._seal(report))

    def _seal(self, message: Message) -> bytes:
        return encode(message, self.config.session, self.config.key)

    def _unseal(self, data: bytes) -> Message:
        return decode(data, self.config.session, self.config.key)

    # -- the window ----------------------------------------------------------------------

    def _tend_window(self) -> None:
        """Between events: the window system's events; a closed window ends the node; the
        preview's input goes out as a tracker's would."""
        if self.live is None:
            return
        if self.live.closed():
            log.info("%s: the window was closed; leaving", self.config.wall)
            self.running = False
        if self.controls is not None and (tracked := self.controls.advance()) is not None:
            self.session.put(self.keys.tracking, self._seal(tracked))

    def _display(self, k: int, phase: Phase, time_ns: int) -> None:
        self.display_publisher.put(self._seal(DisplayMessage(k, self.config.wall, phase,
                                                             time_ns)))

    # -- control and snapshots -------------------------------------------------------------

    def _on_control(self, message: ControlMessage) -> None:
        if message.command is Command.STOP:
            self.running = False
        elif message.command is Command.SWAP and self.live is not None:
            self.live.swap(message.frame)
        elif message.command is Command.RESYNC and message.target == self.config.wall:
            self._resync(message.source)

    def _resync(self, source: str) -> None:
        """Stream in the snapshot of `source` (a healthy node) and report its frame.

        A node that has just come back may not yet have its direct link to `source`: a
        query then finds nobody at once. It asks again until the deadline (which scales
        with the largest state the scene holds), each time first waiting (on liveliness,
        up to a second) for `source` to be reachable.
        """
        started = time.monotonic()
        deadline = started + transfer_seconds(self.system.capacity)
        key = self.keys.state(source)
        while (remaining := deadline - time.monotonic()) > 0:
            header = fetch_snapshot(self.session, key, self.system, self._unseal, deadline,
                                    self.rejects)
            if header is not None:
                self._loaded(header.frame, source, header.chunks, time.monotonic() - started)
                return
            list(self.session.liveliness().get(self.keys.alive(source),
                                               timeout=min(1.0, max(remaining, 0.01))))
        log.error("%s: no snapshot from %s within %.0f s", self.config.wall, source,
                  deadline - started)

    def _loaded(self, frame: int, source: str, chunks: int, seconds: float) -> None:
        self.done = frame
        state = self.system.checksum()
        log.info("%s: resynced to frame %d from %s: %d particles in %d chunks, %.2f s",
                 self.config.wall, frame, source, state.particles, chunks, seconds)
        self._publish(ReportMessage(frame, self.config.wall, state.digest, state.particles,
                                    state.emitters, 0, 0, self.rejects.total, Status.RESYNCED))

    def _answer(self, kind: str, query: zenoh.Query) -> None:
        """A state query gets our snapshot, streamed; an info query our GPU."""
        wall = self.config.wall
        if kind == "info":
            swap_locked = self.live is not None and self.live.screen.swap_locked
            message = InfoMessage.of_gpu(self.done, wall, self.gpu, swap_locked)
            query.reply(self.keys.info(wall), self._seal(message))
            query.drop()
        else:
            send_snapshot(query, self.keys.state(wall), self.system, self.done, self._seal,
                          self.config.chunk_particles)


def main(config: NodeConfig) -> int:
    """Run one wall node until the master says STOP (or the process is told to end)."""
    with open_session(config.network) as session:
        node = WallNode(config, session)
        declarations = node.declare()
        gpu = node.gpu
        log.info("%s: up on EGL device %d (%s): %s, %s, OpenGL %s", config.wall, gpu["device"],
                 gpu["kind"], gpu["renderer"], gpu["vendor"], gpu["version"])
        try:
            node.run()
        except KeyboardInterrupt:
            log.info("%s: interrupted", config.wall)
        finally:
            for declaration in reversed(declarations):
                declaration.undeclare()
            if node.live is not None:
                node.live.close()
    return 0


def open_node_window(config: NodeConfig, cave: Cave | None) -> WallWindow | None:
    """The node's window (None for a headless node): its wall's, or the preview's."""
    if not (config.display or config.preview):
        return None
    if cave is None:
        raise ContextError("a window needs the CAVE: which wall to draw and how to show it",
                           "give --cave FILE with --display or --preview")
    title = f"cavesim {config.wall}"
    if config.preview:
        size = slots_of(scaled(cave, config.preview_scale))[1]
        return open_window(Display(vsync=False, swap_lock=False), size, title)
    wall = cave.wall(config.wall)
    return open_window(wall.display, wall.resolution, title)


def node_screen(config: NodeConfig, cave: Cave, window: WallWindow,
                system: ParticleSystem) -> WallScreen | PreviewScreen:
    if config.preview:
        return PreviewScreen(window, system, cave, config.preview_scale)
    return WallScreen(window, system, cave.wall(config.wall), cave.eye_separation,
                      config.images, config.render_every)
