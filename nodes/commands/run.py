"""`cavesim run`: the master and its nodes on this machine, with a progress bar.

A node is a process with its own context that draws one wall (the default) or several:
those the CAVE file gives one `node`, or, with `--group-by gpu`, those on one GPU. Each node
computes on the EGL device its plan gives it (`nodes.launch.gpus`); the summary names the
GPU every node reported. report.json is kept current while the master runs (a crash
leaves the last checkpoint) and written whole at the end, with the pictures and plots.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

from rich.console import Console

from cavesim.core.cave import DEFAULT_CAVE
from cavesim.core.errors import CaveError, ContextError, ModelError, SceneError
from cavesim.core.framelog import FRAME_LOG
from cavesim.core.output import check_written, writing
from cavesim.core.scene.model import Engine
from cavesim.core.trajectories import FILE_NAME as TRAJECTORIES
from cavesim.core.wire.credentials import Credentials
from cavesim.tools.reports.run_tables import (
    demo_table,
    forensic_lines,
    frame_cost_table,
    gpu_table,
    summary_table,
)
from cavesim.tools.signals import release_start
from nodes.arguments import (
    DEFAULT_SCENE,
    INTERRUPTED,
    UsageError,
    add_trajectory_arguments,
    cave_file,
    frame_count,
    lost_walls_code,
    master_credentials,
    number_in,
    scene_file,
    session_name,
    trajectories_requested,
    trajectory_node_flags,
    wall_count,
    wall_names,
)
from nodes.budget_flags import add_arguments as add_budget_arguments
from nodes.budget_flags import limits_from
from nodes.launch.cluster import ClusterPlan, run_cluster
from nodes.launch.gpus import GROUPINGS, by_gpu
from nodes.lockstep import LOSS_POLICIES
from nodes.master.process import MasterConfig
from nodes.master.report_file import ReportFile
from nodes.master.run_record import RunRecord
from nodes.master.tolerance import Tolerance
from nodes.mixed_hardware import add_arguments as add_mixed_hardware_arguments
from nodes.mixed_hardware import node_arguments, tolerance_from
from nodes.progress import rated_progress
from nodes.run_folder import add_arguments as add_out_arguments
from nodes.run_folder import own_folder

PREVIEW = "preview"  # the member that shows the whole CAVE on a desktop


@dataclass(frozen=True)
class RunPlan:
    nodes: Mapping[str, tuple[str, ...]]  # each node's walls
    scene: Path
    frames: int
    out: Path
    session: str = "run"
    credentials: Credentials | None = None  # the master's (master.key); nodes get their own
    on_loss: str = "continue"  # a wall lost: go on without it, or "pause" the barrier
    cave: Path | None = None  # with render_every > 0: walls are drawn, composites assembled
    render_every: int = 0
    stereo: bool = False
    gpus: Mapping[str, int] = field(default_factory=dict)  # node -> EGL device (else default)
    display: bool = False  # every wall live in its window ([wall.display] of the CAVE)
    preview: bool = False  # a member "preview" shows the CAVE unfolded in a desktop window
    engine: Engine | None = None  # every wall's particle engine path (None: the scene's)
    tolerance: Tolerance | None = None  # the mixed-hardware mode (None: bit-exact)
    trajectories: tuple[int, int] | None = None  # (N, K): the first wall's node writes them
    limits: Mapping[str, object] = field(default_factory=dict)  # the master's --max-lag and
    # budgets (nodes/budget_flags.py; none: the defaults)

    @property
    def members(self) -> tuple[str, ...]:
        """The nodes in lock-step: the walls', and the preview when there is one."""
        return (*self.nodes, PREVIEW) if self.preview else tuple(self.nodes)

    @property
    def draws(self) -> bool:
        return self.cave is not None and self.render_every > 0

    def node_args(self, node: str) -> tuple[str, ...]:
        """The flags of `node` beyond the cluster's own: its engine path, its walls and how
        it draws them, its GPU, its window."""
        engine = () if self.engine is None else ("--engine", str(self.engine))
        if node == PREVIEW:
            return ("--preview", "--cave", str(self.cave), *engine)
        draws = ("--cave", str(self.cave), "--draws", ",".join(self.nodes[node]),
                 "--render-every", str(self.render_every), "--images", str(self.out / "walls"))
        if self.display:
            return ("--display", *draws, *engine)
        gpu = ("--gpu", str(self.gpus[node])) if node in self.gpus else ()
        if not self.draws:
            return (*gpu, *engine)
        return (*draws, *(("--stereo",) if self.stereo else ()), *gpu, *engine)

    @property
    def trajectory_node(self) -> str | None:
        """The node that writes trajectories.parquet: the first wall's (each holds the same
        bytes); None without --trajectories."""
        return None if self.trajectories is None else next(iter(self.nodes))

    def trajectory_args(self, node: str) -> tuple[str, ...]:
        if node != self.trajectory_node:
            return ()
        return trajectory_node_flags(*self.trajectories, self.frames, MasterConfig.dt, self.out)

    def cluster(self) -> ClusterPlan:
        master = MasterConfig(self.members, self.scene, self.frames, self.session,
                              credentials=self.credentials, on_loss=self.on_loss,
                              tolerance=self.tolerance, frame_log=self.out / FRAME_LOG,
                              forensics=self.out, node_walls=self.nodes, **self.limits)
        drawing = frozenset(self.members) if self.draws or self.display \
            else frozenset({PREVIEW} & set(self.members))
        mixed = node_arguments(self.tolerance)
        return ClusterPlan(master, self.out,
                           {node: (*self.node_args(node), *mixed, *self.trajectory_args(node))
                            for node in self.members},
                           drawing, operators=frozenset({PREVIEW} & set(self.members)))


def run_walls(plan: RunPlan, console: Console) -> dict:
    """Run the cluster to the end (or Ctrl-C), keeping report.json current; write and
    return its final content."""
    plan.out.mkdir(parents=True, exist_ok=True)
    with ReportFile(plan.out / "report.json") as report_file:
        release_start()  # a signal that came while it started is written into the report
        with rated_progress(console) as progress:
            walls = sum(len(w) for w in plan.nodes.values())
            nodes = len(plan.members)
            task = progress.add_task(f"{walls} walls on {nodes} node{'s' * (nodes != 1)}",
                                     total=plan.frames, live="0 live", unit="frames")
            tell_notices = counter_notices(progress.console)

            def checkpoint(record: RunRecord) -> None:
                report_file.checkpoint(record)
                tell_notices(record)

            record = run_cluster(plan.cluster(), lambda k, live: progress.update(
                task, completed=k, live=f"{live:,} live"), checkpoint=checkpoint)
            if record.interrupted:
                console.print(f"[yellow]interrupted ({record.signal}): the cluster was stopped")
            elif record.user_stopped:
                console.print(f"the run ended at the user's request after frame "
                              f"{record.frames} (Esc in the preview window)")
            report = record.summary()
            with writing(plan.out):
                if plan.draws:
                    from cavesim.core.cave.geometry import load_cave
                    from cavesim.tools.reports.run_pictures import assemble_pictures

                    report["images"] = assemble_pictures(
                        load_cave(plan.cave), plan.out, MasterConfig.dt * plan.render_every,
                        progress, "run")
                report["plots"] = [str(p) for p in write_plots(report, plan.out, console)]
            trajectories = plan.out / TRAJECTORIES
            if plan.trajectories is not None:  # its node finished it at STOP, or said why not
                report["trajectories"] = str(trajectories) if trajectories.exists() else None
        report_file.finish(report, record.interrupted, record.user_stopped)
    logs = plan.out / "logs"
    frame_log = plan.out / FRAME_LOG if report["frames"] else None  # none before frame 1
    check_written(report_file.path, logs, *([frame_log] if frame_log else []))
    if plan.trajectories is not None and not report["trajectories"]:
        console.print(f"[yellow]{TRAJECTORIES} was not written: see "
                      f"{logs / (plan.trajectory_node + '.log')}")
    console.print(summary_table(report))
    for line in forensic_lines(report):
        console.print(line, markup=False, highlight=False, soft_wrap=True)
    if report["frame_cost_ms"]:
        console.print(frame_cost_table(report))
    console.print(gpu_table(report))
    if report.get("flight"):
        console.print(demo_table(report))
    written = f", {report['trajectories']}" if report.get("trajectories") else ""
    logged = f", {frame_log}" if frame_log else ""
    console.print(f"wrote {report_file.path}{logged}{written}, logs in {logs}")
    return report


def counter_notices(console: Console) -> Callable[[RunRecord], None]:
    """A checkpoint that prints each counter's notice once (e.g. that the capacity dropped
    particles: `CounterBook.notices`) as soon as the record has it."""
    told = 0

    def tell(record: RunRecord) -> None:
        nonlocal told
        notices = [] if record.counters is None else record.counters.notices
        for notice in notices[told:]:
            console.print(notice, style="yellow", markup=False, highlight=False,
                          soft_wrap=True)
        told = len(notices)

    return tell


def write_plots(report: dict, out: Path, console: Console) -> list[Path]:
    """The brownout demo's plots of a helicopter run (none for other scenes)."""
    if not report.get("flight"):
        return []
    from cavesim.tools.reports.demo import write_demo_plots  # matplotlib: only when there is a plot

    paths = write_demo_plots(report, out)
    check_written(*paths)
    console.print(f"wrote {len(paths)} plots in {out / 'plots'}")
    return paths


def add(commands) -> None:
    parser = commands.add_parser("run", help="master + the nodes of the walls on this machine")
    walls = parser.add_mutually_exclusive_group()
    walls.add_argument("--cave", type=cave_file, default=DEFAULT_CAVE,
                       help=f"CAVE geometry whose walls are drawn (default: {DEFAULT_CAVE})")
    walls.add_argument("--walls", type=wall_count, help="N undrawn walls instead of a CAVE")
    parser.add_argument("--group-by", choices=GROUPINGS, default="cave",
                        help="which walls share a node (one process, one context, one step "
                             "a frame): as the CAVE file's `node = ...` says, each wall its "
                             "own where it says none (cave, the default); one node per wall "
                             "(wall); the walls on one GPU (gpu)")
    parser.add_argument("--render-every", type=number_in(int, 0, 10**9, "frames"), default=10,
                        help="each wall writes its picture every K frames (default 10; 0: never)")
    parser.add_argument("--stereo", action="store_true",
                        help="draw each wall for both eyes (side by side in its picture or "
                             "window)")
    parser.add_argument("--display", action="store_true",
                        help="every wall live in its own window, as the CAVE file's "
                             "[wall.display] says, swap-locked (needs an X display)")
    parser.add_argument("--preview", action="store_true",
                        help="one desktop window with every wall unfolded, live; its keys, "
                             "mouse and gamepad move the head and fly the wand")
    parser.add_argument("--scene", type=scene_file, default=DEFAULT_SCENE,
                        help=f"the scene file (default: {DEFAULT_SCENE})")
    parser.add_argument("--engine", type=Engine, choices=list(Engine),
                        help="every node's particle engine path, instead of the scene's "
                             "[simulation] engine: gs_tf (geometry shader + transform "
                             "feedback, the default), compute (compute shaders, same bytes) "
                             "or auto (each node times both at start-up; the run steps with "
                             "the path most nodes found faster)")
    parser.add_argument("--frames", type=frame_count,
                        help="default: the scene's wand timeline to its end, else 600")
    add_out_arguments(parser, "run", "the run's report, frame log, logs and pictures")
    parser.add_argument("--session", default="run", type=session_name)
    parser.add_argument("--on-loss", choices=LOSS_POLICIES,
                        help="a wall lost (its node gone, or silent 10 s in the barrier): "
                             "continue without it, or pause until it is back (at most 300 s). "
                             "Default: continue, but the run then exits 1 when a wall is lost "
                             "for good; give --on-loss continue to accept that")
    parser.add_argument("--key-file", type=Path,
                        help="the session's master.key (`cavesim keys`): every message signed; "
                             "each node gets its own wall's key, and the --preview window an "
                             "operator's key too (its pause, reset and Esc), issued for the "
                             "run (never written into --out)")
    add_budget_arguments(parser)
    add_mixed_hardware_arguments(parser, master=True)
    add_trajectory_arguments(parser)
    parser.set_defaults(handler=run, holds_start=True)  # until report.json is open


def run(args: argparse.Namespace, console) -> int:
    credentials = master_credentials(args.key_file, "run")
    scene, cave = _checked_files(args)  # before anything is started
    walls = wall_names(args.walls) if args.walls else cave.names
    if (args.display or args.preview) and args.walls:
        raise UsageError("cavesim run: error: argument --display/--preview: windows show the "
                         "walls of a CAVE; use --cave, not --walls")
    nodes, gpus = _nodes(args, walls, cave)
    if PREVIEW in walls or PREVIEW in nodes:
        raise UsageError(f"cavesim run: error: argument --cave: a wall or node may not be "
                         f"called {PREVIEW!r} (the preview's name)")
    tolerance = tolerance_from(args, tuple(nodes), "run")
    trajectories = trajectories_requested(args, "run")
    frames = args.frames or default_frames(scene)
    with own_folder(args.out, "run", args.force) as folder:
        plan = RunPlan(nodes, args.scene, frames, folder.path, args.session, credentials,
                       on_loss=args.on_loss or "continue",
                       cave=None if args.walls else args.cave, render_every=args.render_every,
                       stereo=args.stereo, gpus=gpus, display=args.display,
                       preview=args.preview, engine=args.engine, tolerance=tolerance,
                       trajectories=trajectories, limits=limits_from(args))
        report = run_walls(plan, console)
    if report["interrupted"]:
        return INTERRUPTED
    return lost_walls_code(report["final"].get("lost", ()), args.on_loss, "run")


def default_frames(scene, dt: float = 1 / 60) -> int:
    """Frames to play a scene's wand timeline to its end (600 without a timeline)."""
    helicopter = scene.helicopter
    if helicopter is None or not helicopter.timeline:
        return 600
    return round(helicopter.timeline[-1].t / dt)


def _checked_files(args: argparse.Namespace):
    """The run's scene and CAVE (None with --walls), checked before any process starts."""
    from cavesim.core.cave.geometry import load_cave
    from cavesim.core.scene import load_scene
    from cavesim.gpu.render.gltf_model import helicopter_model

    try:
        scene = load_scene(args.scene)
        helicopter_model(scene)  # a model file is read here, not first on every wall
    except (SceneError, ModelError) as e:
        raise UsageError(f"cavesim run: error: argument --scene: {e}") from e
    if args.walls:
        return scene, None
    try:
        return scene, load_cave(args.cave)
    except CaveError as e:
        raise UsageError(f"cavesim run: error: argument --cave: {e}") from e


def _nodes(args: argparse.Namespace, walls: tuple[str, ...],
           cave) -> tuple[dict[str, tuple[str, ...]], dict[str, int]]:
    """Each node's walls, as --group-by says, and the EGL device of each node that is given
    one: the CAVE file's `gpu`, else spread over this machine's GPUs (none with --display:
    a window computes on its X display's GPU)."""
    from cavesim.gpu.gl.devices import list_devices
    from nodes.launch.gpus import spread_walls

    pinned = {} if cave is None else {w.name: w.gpu for w in cave.walls if w.gpu is not None}
    devices = () if args.display else list_devices()  # no EGL: its error says what to install
    try:
        if args.group_by == "gpu":
            return by_gpu(walls, {} if args.display else spread_walls(walls, pinned, devices))
        nodes = {w: (w,) for w in walls} if cave is None or args.group_by == "wall" \
            else cave.nodes
        pinned = {node: pinned[w[0]] for node, w in nodes.items() if w[0] in pinned}
        return nodes, {} if args.display else spread_walls(tuple(nodes), pinned, devices)
    except ContextError as e:
        raise UsageError(f"cavesim run: error: argument --cave: {args.cave}: {e}") from e
