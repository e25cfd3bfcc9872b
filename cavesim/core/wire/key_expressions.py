"""Zenoh key expressions of one cavesim session: every key lives under its prefix."""

from __future__ import annotations

import re
from dataclasses import dataclass

from cavesim.core.limits import NAME_RE

RUN_RE = re.compile(r"[0-9a-f]{16}")  # a run id in a key: as master_alive writes it


def check_name(what: str, name: str) -> str:
    """A session or wall name: 1-32 of letters, digits, '_' and '-' (safe in key expressions)."""
    if not isinstance(name, str) or not NAME_RE.fullmatch(name):
        raise ValueError(f"{what} must be 1-32 letters, digits, '_' or '-', got {name!r}")
    return name


@dataclass(frozen=True)
class SessionKeys:
    session: str

    def __post_init__(self) -> None:
        check_name("session", self.session)

    @property
    def prefix(self) -> str:
        return f"cavesim/{self.session}"

    @property
    def frame(self) -> str:
        return f"{self.prefix}/frame"

    @property
    def control(self) -> str:
        return f"{self.prefix}/control"

    @property
    def tracking(self) -> str:
        """Where trackers publish head and wand; the master samples it once per frame."""
        return f"{self.prefix}/tracking"

    def report(self, node: str = "*") -> str:
        return f"{self.prefix}/report/{node}"

    def state(self, node: str = "*") -> str:
        return f"{self.prefix}/state/{node}"

    def display(self, node: str = "*") -> str:
        """Where a displaying wall reports drawing and swapping a frame (the swap barrier)."""
        return f"{self.prefix}/display/{node}"

    def blocks(self, node: str = "*") -> str:
        """Where a node answers block requests about its state (forensics, delta resync)."""
        return f"{self.prefix}/blocks/{node}"

    def info(self, node: str = "*") -> str:
        """Where a node answers the master's question: which GPU do you compute on?"""
        return f"{self.prefix}/info/{node}"

    def alive(self, node: str = "*") -> str:
        return f"{self.prefix}/alive/{node}"

    def master_alive(self, run_id: int | None = None) -> str:
        """The liveliness token of the master of run `run_id` (None: of every master): a
        node notices when its master is gone, a master that another one is there."""
        run = "*" if run_id is None else f"{run_id:016x}"
        return f"{self.prefix}/master_alive/{run}"

    def run_of(self, key: str) -> int | None:
        """The run id at the end of a master's liveliness key (None: not 16 hex digits)."""
        run = self.node_of(key)
        return int(run, 16) if RUN_RE.fullmatch(run) else None

    def node_of(self, key: str) -> str:
        """The wall name at the end of a report, state, blocks, info or alive key."""
        return str(key).rsplit("/", 1)[-1]
