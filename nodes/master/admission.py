"""How a wall enters the master's run, up to its WELCOME: its liveliness token appears, the
master asks for its info (GPU, swap lock, a fresh nonce; again every INFO_RETRY while it has
not joined), and a wall of the run's scene gets a WELCOME naming that nonce and the run's
scene (a node that probed its engine path waits for the run's: `engine_choice.py`). A wall
of another scene is refused here, in one line, and refuses the WELCOME itself.

The WELCOMEd node reports JOINED; what follows (membership, the resync that admits a late
wall) is `nodes/master/process.py`'s and `nodes/lockstep.py`'s.
"""

from __future__ import annotations

import logging
import time
from pathlib import Path

from cavesim.core.wire import Command, ControlMessage, InfoMessage
from nodes.master.engine_choice import EngineChoice
from nodes.master.run_record import RunRecord

log = logging.getLogger("cavesim.master")
INFO_RETRY = 2.0  # s before a wall that is up but has not joined is asked again


class Admission:
    """The walls that are up, what each said of itself, and their WELCOMEs."""

    def __init__(self, walls: tuple[str, ...], scene: Path, scene_digest: str, link,
                 record: RunRecord) -> None:
        """`link`: the master's (it asks for info and sends the WELCOMEs)."""
        self.scene, self.scene_digest = scene, scene_digest  # every wall must hold this scene
        self.link, self.record = link, record
        self.engines = EngineChoice(walls)  # the path of the nodes that probed theirs
        self.up: set[str] = set()  # walls whose liveliness token is there
        self.asked: dict[str, float] = {}  # wall -> when its info was last asked for
        self.swap_locked: dict[str, bool] = {}  # per wall, from its info answer
        self.wrong_scene: dict[str, str] = {}  # wall -> the line refusing its other scene

    def came_up(self, wall: str) -> None:
        """`wall`'s liveliness token appeared: ask it about itself."""
        self.up.add(wall)
        self._ask(wall)

    def went_down(self, wall: str) -> None:
        self.up.discard(wall)

    def ask_again(self, alive: frozenset[str]) -> None:
        """Walls that are up but have not joined (not `alive`): ask again (a lost query, a
        slow start)."""
        now = time.monotonic()
        for wall in self.up - alive:
            if now - self.asked.get(wall, 0.0) >= INFO_RETRY:
                self._ask(wall)

    def described(self, info: InfoMessage, frame: int) -> None:
        """A wall described itself while `frame` is in flight: note its GPU and swap lock,
        and welcome it into the run with its own nonce and the run's scene."""
        self.swap_locked[info.node] = info.swap_locked
        if info.scene != self.scene_digest:
            refusal = (f"wall {info.node} holds scene {info.scene or 'none'}, this run's "
                       f"scene {self.scene} is {self.scene_digest}: give every host the same "
                       f"scene file")
            if self.wrong_scene.get(info.node) != refusal:
                log.error("master: %s", refusal)
            self.wrong_scene[info.node] = refusal
        else:
            self.wrong_scene.pop(info.node, None)
        for ready in self.engines.described(info, started=frame > 0):
            engine = self.engines.welcome_engine(ready)
            self.record.gpus[ready.node] = ready.gpu() | (
                {} if engine is None else {"engine": engine.value})
            self.link.send(ControlMessage(frame, Command.WELCOME, ready.node,
                                          digest=self.scene_digest, nonce=ready.nonce,
                                          engine=engine))

    def missing(self, walls: tuple[str, ...], alive: frozenset[str]) -> list[str]:
        """Walls that have not joined or not said whether they are swap-locked (the swap
        barrier needs to know from frame 1)."""
        return sorted((set(walls) - alive) | (set(walls) - set(self.swap_locked)))

    def hints(self, missing: list[str]) -> list[str]:
        """What is known of why each missing wall did not join."""
        return [hint for wall in missing
                if (hint := self.wrong_scene.get(wall) or self.link.sender_hint(wall))]

    def _ask(self, wall: str) -> None:
        self.asked[wall] = time.monotonic()
        self.link.ask_info(wall)  # the answer comes as an event
