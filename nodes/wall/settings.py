"""What a wall node is told to run (`NodeConfig`: from `cavesim node`'s flags, or the
launcher's), read by the node and each of its parts (nodes/wall/process.py)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from cavesim.core.scene import Engine
from cavesim.core.trajectories import TrajectoryRequest
from cavesim.core.wire import Credentials
from cavesim.core.wire.network import NetworkSettings
from cavesim.core.wire.snapshot import CHUNK_PARTICLES
from nodes.faults import SLOW_DELAY, STRAGGLE_DELAY, Fault


@dataclass(frozen=True)
class NodeConfig:
    name: str  # the node's, in the run: its wall's, or a node the CAVE file gives walls
    scene: Path
    session: str = "default"
    network: NetworkSettings = NetworkSettings()
    credentials: Credentials | None = None  # wall-NAME.key: signs as this node, checks the master's
    operator: Credentials | None = None  # operator-NAME.key: signs what the preview sends
    faults: tuple[Fault, ...] = ()
    slow_delay: float = SLOW_DELAY
    straggle_delay: float = STRAGGLE_DELAY
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
