"""What a master is told to run (`MasterConfig`, from the command line or a test) and the
link it runs over (`Link`: Zenoh's in nodes/master/link.py, or a test's in memory)."""

from __future__ import annotations

import queue
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Protocol

from cavesim.core.wire import (
    BlockReply,
    BlockRequest,
    ControlMessage,
    Credentials,
    FrameMessage,
    TrackingMessage,
)
from cavesim.core.wire.network import NetworkSettings
from cavesim.core.wire.rejects import RejectCounter
from nodes.master.budgets import BREACH, BUDGETS, LAG, Budget
from nodes.master.events import Event
from nodes.master.stragglers import DEFAULT_MAX_LAG
from nodes.master.tolerance import Tolerance
from nodes.master.user_requests import Controller


@dataclass(frozen=True)
class MasterConfig:
    walls: tuple[str, ...]  # the members: one node each, named after its wall or its own
    scene: Path
    frames: int
    session: str = "default"
    network: NetworkSettings = NetworkSettings()
    credentials: Credentials | None = None  # master.key: signs frames and commands
    dt: float = 1 / 60
    clock_seed: int = 0
    barrier_timeout: float = 2.0
    join_timeout: float = 60.0
    on_loss: str = "continue"  # drop a lost node and go on, or "pause" until it is back
    evict_after: float = 10.0  # s a member may stay silent in the barrier (continue)
    max_pause: float = 300.0  # s the barrier holds for a silent member (pause)
    max_lag: float = DEFAULT_MAX_LAG  # s a member may report after half the members did
    lag_budget: Budget = BUDGETS[LAG]  # lags of a member before it is given up
    breach_budget: Budget = BUDGETS[BREACH]  # divergences (breaches) before it is given up
    check_every: int = 1
    tolerance: Tolerance | None = None  # mixed hardware: drift from an authority, not bits
    frame_log: Path | None = None
    forensics: Path | None = None  # the run's folder: divergences/frame_<k>.json go there
    realtime: bool = False  # pace frames by the wall clock (see cavesim/core/clock.py)
    max_frame_time: float = 0.1
    max_substeps: int = 4
    node_walls: Mapping[str, tuple[str, ...]] = field(default_factory=dict)  # a node's walls,
    # for the report, where it draws others than the one named after it


class Link(Protocol):
    """The master's side of the wire (`nodes/master/link.py`, or a test's memory)."""

    events: queue.Queue[Event]
    run_id: int
    rejects: RejectCounter  # the messages it refused, by reason
    dropped: int  # events its full queue could not take
    tracking: TrackingMessage | None  # the latest tracker message with a pose
    controller: Controller | None  # the latest session controls taken, and their sender

    def send(self, message: FrameMessage | ControlMessage) -> None: ...

    def ask_info(self, wall: str) -> None: ...

    def sender_hint(self, wall: str) -> str | None: ...

    def ask_blocks(self, wall: str, request: BlockRequest) -> BlockReply | None:
        """`wall`'s checked reply to a block request (None: refused, or none in time)."""
