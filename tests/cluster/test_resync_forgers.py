"""A resync under insiders: eight peers, each holding a healthy wall's own key, answer the
resyncing node's state query with a signed header of the wanted frame and checksum, then a
broken chunk (those holding the key of the wall asked are followed until the chunk breaks;
the others are refused by their signature).
The node follows one replier at a time, drops each broken stream and no longer hears
that replier, so it comes to the honest stream (the master resyncs it again if its first
deadline passes first), and it still leaves on --master-wait once the master is gone."""

from __future__ import annotations

import itertools
import os
import re
import signal
import threading
import time
from pathlib import Path

import numpy as np
import pytest
import zenoh
from master_process import spawn_master

from cavesim.core.errors import ProtocolError
from cavesim.core.records import EMITTER_DTYPE, PARTICLE_BYTES
from cavesim.core.scene import load_scene
from cavesim.core.wire import SessionKeys, StateRequest, encode
from cavesim.core.wire.credentials import WALL, Credentials, generate
from cavesim.core.wire.envelope import decode_envelope
from cavesim.core.wire.key_files import write_key_files
from cavesim.core.wire.network import NetworkSettings, open_session
from cavesim.core.wire.payloads.state_transfer import SnapshotChunk, SnapshotHeader
from nodes.faults import parse_fault
from nodes.launch.launcher import LocalCluster

ROOT = Path(__file__).parents[2]
MINIMAL = ROOT / "config" / "scenes" / "minimal.toml"
WALLS = ("front", "left", "right")
FORGERS = 8
CHUNK = 16  # particles per forged chunk
MASTER_WAIT = 5.0  # s the nodes wait for a new master

pytestmark = pytest.mark.slow


class Forgers:
    """FORGERS peers of their own, each holding one of `insiders` in turn, answering every
    state query with a signed header of the asked frame and checksum, then `broken` (a
    chunk sent twice, or a short one); each holds its queries open, as a hostile peer
    would, until it is closed."""

    def __init__(self, endpoint: str, session: str, insiders: list[Credentials],
                 broken: str) -> None:
        self.name, self.broken = session, broken
        self.emitters = len(load_scene(MINIMAL).emitters)
        self.keys = SessionKeys(session)
        self.answered = 0
        self._held: list[zenoh.Query] = []
        self._lock = threading.Lock()
        self._sessions = [open_session(NetworkSettings(connect=(endpoint,)))
                          for _ in range(FORGERS)]
        self._queryables = [
            s.declare_queryable(self.keys.state(),
                                lambda query, member=member: self._forge(query, member))
            for s, member in zip(self._sessions, itertools.cycle(insiders))]

    def _forge(self, query: zenoh.Query, member: Credentials) -> None:
        try:
            envelope = decode_envelope(query.payload.to_bytes(), self.name, member)
        except (ProtocolError, AttributeError):
            return
        request = envelope.message
        if not isinstance(request, StateRequest):
            return
        chunk = SnapshotChunk(request.frame, 0, bytes(CHUNK * PARTICLE_BYTES))
        second = chunk if self.broken == "duplicate" else \
            SnapshotChunk(request.frame, 1, bytes(CHUNK * PARTICLE_BYTES // 2))
        header = SnapshotHeader(request.frame, 1, 2 * CHUNK, CHUNK, request.digest,
                                np.zeros(self.emitters, EMITTER_DTYPE))
        try:
            for message in (header, chunk, second):
                query.reply(str(query.key_expr), encode(message, self.name, member,
                                                        envelope.run_id))
        except zenoh.ZError:
            return
        with self._lock:
            self.answered += 1
            self._held.append(query)

    def close(self) -> None:
        for queryable in self._queryables:
            queryable.undeclare()
        with self._lock:
            for query in self._held:
                query.drop()
        for session in self._sessions:
            session.close()


def wait_for_line(path: Path, texts: tuple[str, ...], seconds: float) -> str:
    """The first of `texts` that `path` comes to hold within `seconds`."""
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        text = path.read_text() if path.exists() else ""
        for wanted in texts:
            if wanted in text:
                return wanted
        time.sleep(0.2)
    raise AssertionError(f"none of {texts} in {path} within {seconds:g} s:\n"
                         f"{path.read_text() if path.exists() else ''}")


@pytest.mark.parametrize("broken", ["duplicate", "short"])
def test_a_resync_among_eight_forgers_heals_and_the_node_still_leaves_on_master_wait(
        tmp_path, broken):
    credentials = generate()
    master_key, *_ = write_key_files(tmp_path / "keys", credentials, WALLS)
    insiders = [credentials.issue(WALL, wall) for wall in WALLS if wall != "left"]
    session = f"forge{broken}{os.getpid()}"
    with LocalCluster(MINIMAL, tmp_path, session, keys=tmp_path / "keys") as cluster:
        forgers = Forgers(cluster.master_endpoint, session, insiders, broken)
        try:
            for wall in WALLS:
                faults = (parse_fault("bitflip@30:left"),) if wall == "left" else ()
                cluster.start_node(wall, faults, extra=(
                    "--resync", "full", "--on-master-loss", "wait",
                    "--master-wait", str(MASTER_WAIT)))
            master = spawn_master(cluster, WALLS, 1_000_000, key_file=master_key)
            wait_for_line(cluster.log_path("left"), ("resynced to frame",), 120)
            os.killpg(master.pid, signal.SIGKILL)  # no STOP: the nodes must leave on their own
            master.wait(timeout=10)
            ended = time.monotonic()
            exits = {wall: node.wait(timeout=MASTER_WAIT + 60)
                     for wall, node in cluster.nodes.items()}
            waited = time.monotonic() - ended
        finally:
            forgers.close()
    assert forgers.answered >= 1
    assert set(exits) == set(WALLS) and waited < MASTER_WAIT + 30, (exits, waited)
    left = cluster.log_path("left").read_text()
    # healed from an honest wall: the vote's source, or the next holder where a try failed
    assert re.search(r"resynced to frame \d+ from (front|right): \d+ particles", left)
    assert "no new master came within" in left and "Traceback" not in left
