"""Fuzzing a running master and two wall nodes: whatever they reject changes nothing.

A third zenoh peer (this test) publishes hypothesis-drawn junk on the session's frame,
control and report keys while the cluster runs 400 frames with a shared key: random
bytes, valid but unsigned messages, messages signed with a wrong key or of another
session, mutated copies of the cluster's own signed traffic, and the master's signed
frames replayed on report keys. The fuzzer never holds the key, so it cannot forge.
Afterwards the run must be clean (400 frames, no divergence, no resync), every junk
message must be counted as rejected, and an in-process replay of the frame log must
reproduce every agreed checksum: the junk changed no state.
"""

from __future__ import annotations

import json
import secrets
import threading
from collections import Counter
from dataclasses import dataclass
from pathlib import Path

import pytest
import zenoh
from cluster_helpers import Mutation, credential_sets, messages, mutations, names
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st
from master_process import spawn_master

from cavesim.core.errors import ProtocolError
from cavesim.core.framelog import read_frame_log
from cavesim.core.scene import load_scene
from cavesim.core.wire import SessionKeys, decode, encode
from cavesim.core.wire.credentials import Credentials, generate
from cavesim.core.wire.envelope import HEADER
from cavesim.core.wire.key_files import read_key_file, write_key_files
from cavesim.core.wire.network import NetworkSettings, zenoh_config
from cavesim.gpu.engine import FrameInput, ParticleSystem
from nodes.launch.launcher import LocalCluster

SCENE = Path(__file__).parents[2] / "config/scenes/minimal.toml"
WALLS = ("front", "left")
FRAMES = 400
EXAMPLES = 150
EXAMPLES_PER_FRAME = 2  # spreads the fuzz over the first ~75 frames of the run
CATEGORIES = ("random", "unsigned", "wrong-key", "other-session", "mutated", "replayed")
STARTUP_TIMEOUT = 60.0  # s for the walls to come up (GL context, shader compilation)


@dataclass(frozen=True)
class Fuzz:
    """One fuzz example: what to send and on which report key."""

    category: str
    data: bytes = b""  # ready to send, for the categories that need no captured traffic
    mutation: Mutation | None = None  # "mutated": applied to a captured signed message
    captured: str = "frame"  # "mutated": which traffic to mutate, "frame" or "report"
    wall: str = WALLS[0]  # the report/<wall> key this example goes to


def fuzz_strategies(session: str) -> dict[str, st.SearchStrategy[Fuzz]]:
    """One strategy per category of junk."""
    others = names.filter(lambda name: name != session)
    walls = st.sampled_from(WALLS)
    sizes = st.integers(0, 600)  # drawn first, so short and long junk are equally likely
    return {
        "random": st.builds(Fuzz, st.just("random"), sizes.flatmap(
            lambda n: st.binary(min_size=n, max_size=n)), wall=walls),
        "unsigned": st.builds(lambda m, wall: Fuzz("unsigned", encode(m, session), wall=wall),
                              messages(), walls),
        "wrong-key": st.builds(
            lambda m, key, wall: Fuzz("wrong-key", encode(m, session, key), wall=wall),
            messages(), credential_sets, walls),
        "other-session": st.builds(
            lambda m, other, key, wall: Fuzz("other-session", encode(m, other, key), wall=wall),
            messages(), others, st.none() | credential_sets, walls),
        "mutated": st.builds(Fuzz, st.just("mutated"), mutation=mutations,
                             captured=st.sampled_from(["frame", "report"]), wall=walls),
        "replayed": st.builds(Fuzz, st.just("replayed"), wall=walls),
    }


def draw_examples(strategy: st.SearchStrategy, count: int) -> list:
    """Up to `count` examples of `strategy`, the same ones on every run (failures reproduce)."""
    drawn = []

    @settings(max_examples=count, deadline=None, database=None, derandomize=True,
              phases=[Phase.generate], suppress_health_check=list(HealthCheck))
    @given(strategy)
    def collect(example):
        drawn.append(example)

    collect()
    return drawn


def draw_plan(session: str) -> list[Fuzz]:
    """EXAMPLES examples, the categories taken in turn (so each is spread over the run); a
    category with few distinct examples (replayed: one per wall) repeats them."""
    per_category = EXAMPLES // len(CATEGORIES)
    strategies = fuzz_strategies(session)
    drawn = [draw_examples(strategies[category], per_category) for category in CATEGORIES]
    return [examples[i % len(examples)] for i in range(per_category) for examples in drawn]


class Traffic:
    """What the cluster itself sends, as the fuzzer hears it: the latest frame and report."""

    def __init__(self, walls: tuple[str, ...]) -> None:
        self.changed = threading.Condition()
        self.walls = set(walls)
        self.alive: set[str] = set()
        self.frame = 0  # highest frame number the master has published
        self.latest: dict[str, bytes] = {}

    def on_frame(self, sample: zenoh.Sample) -> None:
        data = sample.payload.to_bytes()
        with self.changed:
            self.latest["frame"] = data
            self.frame = max(self.frame, HEADER.unpack_from(data)[7])
            self.changed.notify_all()

    def on_report(self, sample: zenoh.Sample) -> None:
        with self.changed:
            self.latest["report"] = sample.payload.to_bytes()
            self.changed.notify_all()

    def on_alive(self, sample: zenoh.Sample) -> None:
        with self.changed:
            self.alive.add(str(sample.key_expr).rsplit("/", 1)[-1])
            self.changed.notify_all()

    def wait(self, condition, timeout: float, what: str) -> None:
        with self.changed:
            assert self.changed.wait_for(condition, timeout), f"timed out waiting for {what}"


def fuzz_the_run(session: zenoh.Session, keys: SessionKeys, traffic: Traffic,
                 plan: list[Fuzz]) -> list[tuple[str, bytes]]:
    """Publish the plan while the cluster runs, a few examples per frame; what was sent."""
    block = zenoh.CongestionControl.BLOCK  # never drop junk: every message must be counted
    publishers = {key: session.declare_publisher(key, congestion_control=block)
                  for key in (keys.frame, keys.control, *map(keys.report, WALLS))}
    traffic.wait(lambda: traffic.frame >= 1 and "report" in traffic.latest, STARTUP_TIMEOUT,
                 "the first frame and report")
    sent = []
    first = traffic.frame
    for i, fuzz in enumerate(plan):
        traffic.wait(lambda i=i: traffic.frame >= first + i // EXAMPLES_PER_FRAME, 10.0,
                     f"frame {first + i // EXAMPLES_PER_FRAME}")
        with traffic.changed:
            captured = dict(traffic.latest)
        if fuzz.category == "replayed":  # a signed frame where a report belongs
            targets, data = [keys.report(fuzz.wall)], captured["frame"]
        else:
            targets = [keys.frame, keys.control, keys.report(fuzz.wall)]
            data = fuzz.mutation.apply(captured[fuzz.captured]) if fuzz.mutation else fuzz.data
        for key in targets:
            publishers[key].put(data)
            sent.append((key, data))
    for publisher in publishers.values():
        publisher.undeclare()
    return sent


def expected_master_rejects(sent: list[tuple[str, bytes]], keys: SessionKeys,
                            key: Credentials) -> Counter:
    """The reasons the master must count for what went to report keys (checked with the key,
    after the run: the fuzzer itself never holds it)."""
    reasons = Counter()
    for where, data in sent:
        if where.startswith(keys.report("")):
            try:
                decode(data, keys.session, key)
                reasons["unexpected"] += 1  # valid, but not a report: the replayed frames
            except ProtocolError as e:
                reasons[e.reason] += 1
    return reasons


def replay(ctx, log: Path) -> int:
    """Step an engine through the frame log; every digest must be the agreed one."""
    header, frames = read_frame_log(log)
    assert header["walls"] == list(WALLS)
    system = ParticleSystem(ctx, load_scene(SCENE))
    count = 0
    try:
        for count, logged in enumerate(frames, 1):
            assert logged.message.frame == count
            system.step(FrameInput(logged.message.inputs.dt,
                                   logged.message.inputs.random_transform))
            state = system.checksum()
            assert (state.digest, state.particles) == (logged.digest, logged.particles), \
                f"frame {count}: the replay differs from the cluster's agreed state"
    finally:
        system.release()
    return count


@pytest.mark.slow
def test_fuzzed_cluster_rejects_everything_and_keeps_its_state(tmp_path, ctx):
    session_name = f"fuzz-{secrets.token_hex(6)}"
    keys = SessionKeys(session_name)
    master_key, *wall_keys = write_key_files(tmp_path / "keys", generate(), WALLS)
    plan = draw_plan(session_name)
    per_category = EXAMPLES // len(CATEGORIES)
    assert Counter(fuzz.category for fuzz in plan) == dict.fromkeys(CATEGORIES, per_category)
    traffic = Traffic(WALLS)

    with LocalCluster(SCENE, tmp_path, session_name, keys=tmp_path / "keys") as cluster:
        master = spawn_master(cluster, WALLS, frames=FRAMES, extra=("--barrier-timeout", "1"),
                              key_file=master_key)
        config = zenoh_config(NetworkSettings(connect=(cluster.master_endpoint,)))
        # retry the master's endpoint often: it listens a moment after its process starts
        config.insert_json5("connect/retry", '{"period_init_ms": 50, "period_max_ms": 200}')
        with zenoh.open(config) as session:
            remote = zenoh.Locality.REMOTE
            listeners = [
                session.declare_subscriber(keys.frame, traffic.on_frame, allowed_origin=remote),
                session.declare_subscriber(keys.report(), traffic.on_report,
                                           allowed_origin=remote),
                session.liveliness().declare_subscriber(keys.alive(), traffic.on_alive,
                                                        history=True),
            ]
            for wall in WALLS:
                cluster.start_node(wall)
            traffic.wait(lambda: traffic.walls <= traffic.alive, STARTUP_TIMEOUT,
                         f"the walls {WALLS} to be alive")
            sent = fuzz_the_run(session, keys, traffic, plan)
            fuzzed_until = traffic.frame
            for listener in listeners:
                listener.undeclare()
        progress = [json.loads(line) for line in master.stdout]
        assert master.wait(timeout=60) == 0
        exits = {wall: node.wait(timeout=30) for wall, node in cluster.nodes.items()}
    assert all(p.poll() is not None for p in (master, *cluster.nodes.values()))

    assert exits == dict.fromkeys(WALLS, 0)
    for log in (tmp_path / "logs").glob("*.log"):
        assert "Traceback" not in log.read_text(), f"{log.name} shows a crash"
    assert [p["frame"] for p in progress] == list(range(1, FRAMES + 1))
    assert fuzzed_until < FRAMES - 100, "the fuzz ran into the end of the run"

    report = json.loads((tmp_path / "report.json").read_text())
    assert report["frames"] == FRAMES and not report["interrupted"]
    assert report["divergences"] == [] and report["resyncs"] == []
    assert report["losses"] == [] and report["joins"] == []
    rejected = report["rejected_messages"]
    to_nodes = sum(1 for where, _ in sent if where in (keys.frame, keys.control))
    assert to_nodes > 0 and rejected["nodes"] == dict.fromkeys(WALLS, to_nodes)
    master_expected = expected_master_rejects(sent, keys, read_key_file(wall_keys[0], "wall"))
    assert sum(master_expected.values()) > 0 and rejected["master"] == master_expected

    assert replay(ctx, tmp_path / "frames.log") == FRAMES
