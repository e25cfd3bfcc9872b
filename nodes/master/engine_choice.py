"""The one engine path that the nodes of `engine = "auto"` step with in a run.

Each such node probed both paths on its own context and names the faster in its info
(`auto`). The master holds their WELCOMEs until every member has described itself, then
takes the path most of them chose (a tie: GS/TF, the reference) and names it in every
WELCOME; a node whose own choice differs switches (both paths give the same bytes, so only
time is at stake, and one path keeps the walls' frame times alike). A node that describes
itself once the run has begun is told the path already chosen. Nodes given a path by their
scene or `--engine` keep it.
"""

from __future__ import annotations

from collections import Counter

from cavesim.core.scene.model import Engine
from cavesim.core.wire import InfoMessage


class EngineChoice:
    def __init__(self, members: tuple[str, ...]) -> None:
        self.members = frozenset(members)
        self.path: Engine | None = None  # chosen, once every member has described itself
        self.votes: dict[str, Engine] = {}  # member -> the path its probe chose
        self._described: set[str] = set()
        self._waiting: dict[str, InfoMessage] = {}

    def described(self, info: InfoMessage, started: bool) -> list[InfoMessage]:
        """Note `info`; the infos whose WELCOME may go out now (`welcome_engine` says with
        which path)."""
        self._described.add(info.node)
        if not info.auto:
            return [info]
        self.votes[info.node] = info.engine
        self._waiting[info.node] = info
        if self.path is None and (started or self.members <= self._described):
            counts = Counter(self.votes.values())
            self.path = max((Engine.GS_TF, Engine.COMPUTE), key=lambda path: counts[path])
        if self.path is None:
            return []
        ready, self._waiting = list(self._waiting.values()), {}
        return ready

    def welcome_engine(self, info: InfoMessage) -> Engine | None:
        """The path a WELCOME names for `info`'s node (None: it keeps its own)."""
        return self.path if info.auto else None
