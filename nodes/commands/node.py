"""`cavesim node`: one node of a cluster of several hosts (`deploy/launch.sh`, the systemd
unit), drawing one wall or the walls the CAVE file gives it; flags in, a typed `NodeConfig`
out."""

from __future__ import annotations

import argparse
from pathlib import Path

from cavesim.core.limits import GPU_RANGE
from cavesim.core.scene.model import Engine
from cavesim.core.wire import Credentials
from cavesim.core.wire.credentials import OPERATOR, WALL
from cavesim.core.wire.key_files import read_key_file
from cavesim.core.wire.payloads.state_transfer import MAX_CHUNK_PARTICLES
from cavesim.core.wire.snapshot import CHUNK_PARTICLES
from nodes.arguments import (
    DEFAULT_SCENE,
    UsageError,
    add_network_arguments,
    add_node_trajectory_arguments,
    cave_file,
    configure_logging,
    network_and_key,
    node_fault_spec,
    number_in,
    output_folder,
    scene_file,
    seconds,
    trajectory_node_request,
    wall_list,
)
from nodes.faults import SLOW_DELAY, STRAGGLE_DELAY
from nodes.lockstep import MASTER_LOSS_POLICIES, RESYNC_MODES
from nodes.mixed_hardware import add_arguments as add_mixed_hardware_arguments
from nodes.mixed_hardware import node_sample_from


def add(commands) -> None:
    parser = commands.add_parser("node", help="one node: a GL context stepping in lock-step, "
                                              "drawing one wall or several")
    parser.add_argument("--node", "--wall", dest="node", type=lambda t: wall_list(t)[0],
                        required=True,
                        help="the node's name in the run: a wall's, or a node that the "
                             "--cave file's `node = NAME` gives several walls")
    parser.add_argument("--scene", type=scene_file, default=DEFAULT_SCENE)
    parser.add_argument("--inject", type=node_fault_spec, action="append", default=[],
                        help="fault to inject into this node, KIND@FRAME (testing)")
    parser.add_argument("--slow-delay", type=seconds, default=SLOW_DELAY,
                        help=f"how long a `slow` fault holds its frame's report (testing; "
                             f"default {SLOW_DELAY:g} s)")
    parser.add_argument("--straggle-delay", type=seconds, default=STRAGGLE_DELAY,
                        help=f"how much longer each frame takes from a `straggler` fault's on "
                             f"(testing; default {STRAGGLE_DELAY:g} s, twice the master's "
                             f"default --max-lag)")
    parser.add_argument("--cave", type=cave_file,
                        help="CAVE geometry (.toml) to draw the node's walls of")
    parser.add_argument("--draws", type=wall_list,
                        help="the walls of --cave this node draws, comma-separated (default: "
                             "those whose `node` it is)")
    parser.add_argument("--render-every", type=number_in(int, 0, 10**9, "frames"), default=0,
                        help="draw the wall every K frames (0: never)")
    parser.add_argument("--images", type=output_folder, help="folder for <wall>/frame_<k>.png")
    parser.add_argument("--stereo", action="store_true", help="draw a left and a right eye")
    parser.add_argument("--gpu", type=number_in(int, *GPU_RANGE, "an EGL device index"),
                        help="EGL device to compute on (default: device 0; `cavesim doctor` "
                             "lists them)")
    parser.add_argument("--engine", type=Engine, choices=list(Engine),
                        help="particle engine path, instead of the scene's [simulation] "
                             "engine: gs_tf (geometry shader + transform feedback), compute, "
                             "or auto (timed at start-up; the master names the run's path)")
    parser.add_argument("--snapshot-chunk", type=number_in(int, 1, MAX_CHUNK_PARTICLES,
                                                           "particles"),
                        default=CHUNK_PARTICLES,
                        help=f"particles per reply of a snapshot this node sends "
                             f"(default: {CHUNK_PARTICLES}, 4 MiB)")
    parser.add_argument("--display", action="store_true",
                        help="show the wall live in a window, as the CAVE file's "
                             "[wall.display] says (needs --cave and an X display)")
    parser.add_argument("--preview", action="store_true",
                        help="show every wall of --cave unfolded in one desktop window; "
                             "keys, mouse and gamepad move the head and fly the wand")
    parser.add_argument("--preview-scale", type=number_in(float, 0.05, 2.0, "a scale"),
                        default=0.5, help="walls' size in the preview (default 0.5)")
    parser.add_argument("--operator-key-file", type=Path, metavar="FILE",
                        help="with --preview and --key-file: an operator's key "
                             "(operator-NAME.key from `cavesim keys --operators NAME`), which "
                             "signs the preview's head, wand and session controls: the master "
                             "takes pause, reset and stop from an operator alone")
    parser.add_argument("--on-master-loss", choices=MASTER_LOSS_POLICIES, default="wait",
                        help="when the master's liveliness goes away: wait --master-wait "
                             "seconds for a new master (default), or exit 1")
    parser.add_argument("--master-wait", type=seconds, default=60.0,
                        help="seconds to wait for a master's welcome, or for a new master "
                             "(default 60); then the node exits 1")
    parser.add_argument("--resync", choices=RESYNC_MODES, default="delta",
                        help="how a RESYNC loads the healthy state: fetch only the records "
                             "under the differing blocks of the checksum tree, falling back "
                             "to the full snapshot (delta, default), or the full snapshot")
    add_node_trajectory_arguments(parser)
    parser.add_argument("--verbose", action="store_true")
    add_mixed_hardware_arguments(parser, master=False)
    add_network_arguments(parser)
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace, console) -> int:
    from nodes.wall.process import main as run_node
    from nodes.wall.settings import NodeConfig

    configure_logging(args.verbose)
    network, credentials = network_and_key(args, "node", WALL, args.node)
    operator = _operator_key(args, credentials)
    if args.render_every and (args.cave is None or args.images is None):
        raise UsageError("cavesim node: error: argument --render-every: drawing needs --cave "
                         "and --images too")
    if args.display and args.preview:
        raise UsageError("cavesim node: error: argument --preview: not with --display (a node "
                         "shows its wall or the whole CAVE)")
    if (args.display or args.preview) and args.cave is None:
        raise UsageError("cavesim node: error: argument --display/--preview: a window needs "
                         "--cave FILE (the wall's geometry and its [wall.display])")
    if (args.display or args.preview) and args.gpu is not None:
        raise UsageError("cavesim node: error: argument --gpu: a window computes on its X "
                         "display's GPU; choose the display ([wall.display] x_display)")
    trajectories, trajectory_folder = trajectory_node_request(args) or (None, None)
    config = NodeConfig(name=args.node, scene=args.scene, session=args.session,
                        network=network, credentials=credentials, operator=operator,
                        faults=tuple(args.inject),
                        slow_delay=args.slow_delay, straggle_delay=args.straggle_delay,
                        cave=args.cave,
                        render_every=args.render_every, images=args.images,
                        walls=_walls_of(args), stereo=args.stereo,
                        chunk_particles=args.snapshot_chunk, gpu=args.gpu,
                        engine=args.engine,
                        display=args.display, preview=args.preview,
                        preview_scale=args.preview_scale, on_master_loss=args.on_master_loss,
                        master_wait=args.master_wait, resync=args.resync,
                        drift_sample=node_sample_from(args, "node"),
                        trajectories=trajectories, trajectory_folder=trajectory_folder)
    return run_node(config)


def _operator_key(args: argparse.Namespace, wall: Credentials | None) -> Credentials | None:
    """The preview's operator key (None without keys): given exactly when a keyed node has
    --preview, and of the same session as the wall's key (UsageError)."""
    path, flag = args.operator_key_file, "--operator-key-file"
    if path is not None and not (args.preview and wall is not None):
        raise UsageError(f"cavesim node: error: argument {flag}: only with --preview and "
                         f"--key-file (it signs the preview's controls in a session with keys)")
    if args.preview and wall is not None and path is None:
        raise UsageError(f"cavesim node: error: argument --preview: with --key-file it needs "
                         f"{flag} FILE too (an operator-NAME.key from `cavesim keys "
                         f"--operators NAME`): the master takes pause, reset and stop from an "
                         f"operator alone")
    if path is None:
        return None
    try:
        operator = read_key_file(path, OPERATOR, flag=flag)
    except ValueError as e:
        raise UsageError(f"cavesim node: error: {e}") from e
    if not operator.same_session(wall):
        raise UsageError(f"cavesim node: error: argument {flag}: {path} is of another "
                         f"session than --key-file {args.key_file} (another `cavesim keys` "
                         f"made it); give the operator key made with this session's keys")
    return operator


def _walls_of(args: argparse.Namespace) -> tuple[str, ...]:
    """The walls of --cave that the node draws: --draws, else those whose `node` it is (a
    wall's own node: that wall); none without --cave or with --preview (every wall)."""
    if args.cave is None or args.preview:
        if args.draws:
            raise UsageError("cavesim node: error: argument --draws: walls of a CAVE: give "
                             "--cave FILE, without --preview")
        return ()
    from cavesim.core.cave.geometry import load_cave

    cave = load_cave(args.cave)
    if args.draws:
        if unknown := [w for w in args.draws if w not in cave.names]:
            raise UsageError(f"cavesim node: error: argument --draws: {args.cave} has no wall "
                             f"{unknown[0]!r}; its walls are {', '.join(cave.names)}")
        return tuple(args.draws)
    if args.node not in cave.nodes:
        raise UsageError(f"cavesim node: error: argument --node: {args.node!r} draws no wall "
                         f"of {args.cave}; its nodes are {', '.join(cave.nodes)}")
    return cave.nodes[args.node]
