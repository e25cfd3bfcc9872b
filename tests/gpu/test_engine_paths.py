"""The compute engine path holds the GS/TF path's bytes, frame by frame, on one driver.

Both paths step on the test session's context from the same inputs: the master's frames
(PCG64 matrices, dt, the helicopter's scene frames as a node decodes them). Every frame's
checksum must agree, and at the end both streams byte for byte; the edge cases (a pool
that overflows, frames with no survivor or no emission, runaway particles) run the same
way. A mixed cluster (walls on both paths) agrees in the master's barrier.
"""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path

import numpy as np
import pytest
from scenes import FOUNTAIN, make_scene, particle_cloud, scene_dict, with_smoke

from cavesim.core.drivers import driver_for
from cavesim.core.errors import SceneError
from cavesim.core.random_texture import draw_transform
from cavesim.core.scene import Engine, load_scene, parse_scene
from cavesim.core.scene.model import ENGINE_PATHS
from cavesim.gpu.engine import FrameInput, ParticleSystem
from cavesim.gpu.gl.denormal_probe import probe
from cavesim.tools.bench.engine_probe import EngineProbe, probe_engines
from nodes.cli import main
from nodes.commands.run import RunPlan
from nodes.launch.cluster import ClusterPlan, run_cluster
from nodes.master.process import MasterConfig

TWO_NODES = {"front": ("front",), "left": ("left",)}  # a plan's nodes and their walls

SCENES = Path(__file__).parents[2] / "config" / "scenes"
FRAMES = 500
DT = 1 / 60


class Pair:
    """One scene on both engine paths, stepped with the same inputs."""

    def __init__(self, ctx, scene) -> None:
        self.gs_tf = ParticleSystem(ctx, dataclasses.replace(scene, engine=Engine.GS_TF))
        self.compute = ParticleSystem(ctx, dataclasses.replace(scene, engine=Engine.COMPUTE))
        self.driver = driver_for(scene)
        self.rng = np.random.Generator(np.random.PCG64(0))  # the master's (clock_seed 0)
        self.size = scene.random_texture_size
        self.frames = 0
        self.counts: list[int] = []
        self.dropped: list[int] = []  # new particles dropped at the capacity, each frame

    def step(self, dt: float = DT) -> None:
        """One master frame on both paths; their checksums and counters must agree."""
        self.frames += 1
        step = self.driver.advance(self.frames * dt, dt, None)
        scene_frame = self.driver.decode(self.driver.encode(step.frame))  # as a node gets it
        inputs = FrameInput(dt, draw_transform(self.rng, self.size))
        for system in (self.gs_tf, self.compute):
            system.step(inputs, scene_frame)
        reference, checked = self.gs_tf.checksum(), self.compute.checksum()
        assert checked == reference, f"frame {self.frames}: {checked} != {reference}"
        counters = self.gs_tf.counters()
        assert self.compute.counters() == counters, f"frame {self.frames}: counters differ"
        self.counts.append(reference.particles)
        self.dropped.append(self.gs_tf.dropped())

    def assert_same_bytes(self) -> None:
        assert self.compute.read_particles().tobytes() == self.gs_tf.read_particles().tobytes()
        assert self.compute.read_emitters().tobytes() == self.gs_tf.read_emitters().tobytes()

    def release(self) -> None:
        self.gs_tf.release()
        self.compute.release()


@pytest.fixture
def pair(ctx):
    made = []

    def make(scene) -> Pair:
        made.append(Pair(ctx, scene))
        return made[-1]

    yield make
    for each in made:
        each.release()


def test_the_scene_chooses_the_path_and_gs_tf_is_the_default():
    data = {"simulation": {"capacity": 10, "seed": 1}}
    assert parse_scene(data).engine is Engine.GS_TF
    data["simulation"]["engine"] = "compute"
    assert parse_scene(data).engine is Engine.COMPUTE
    data["simulation"]["engine"] = "cuda"
    with pytest.raises(SceneError, match=r"simulation.engine = 'cuda' is not allowed: must be "
                                         r"one of 'gs_tf', 'compute', 'auto'"):
        parse_scene(data)
    data["simulation"]["engine"] = "auto"
    assert parse_scene(data).engine is Engine.AUTO


def test_a_system_steps_with_a_path_and_may_switch_keeping_its_bytes(ctx, pair):
    scene = make_scene(emitters=[FOUNTAIN])
    with pytest.raises(ValueError, match="probe `auto` first"):
        ParticleSystem(ctx, dataclasses.replace(scene, engine=Engine.AUTO))
    both = pair(scene)
    for _ in range(30):
        both.step()
    both.gs_tf.use_engine(Engine.COMPUTE)  # now both step with compute ...
    both.compute.use_engine(Engine.GS_TF)  # ... and with GS/TF, swapped
    assert (both.gs_tf.engine, both.compute.engine) == (Engine.COMPUTE, Engine.GS_TF)
    for _ in range(30):
        both.step()
    both.assert_same_bytes()


def test_the_probe_times_both_paths_and_prefers_gs_tf_within_its_margin(ctx):
    probe_result = probe_engines(ctx, load_scene(SCENES / "minimal.toml"))
    assert set(probe_result.seconds) == set(ENGINE_PATHS) and probe_result.particles == 10_000
    assert all(seconds > 0 for seconds in probe_result.seconds.values())
    tie = EngineProbe({Engine.GS_TF: 1.0, Engine.COMPUTE: 0.96}, 10)
    assert tie.faster is Engine.GS_TF
    assert EngineProbe({Engine.GS_TF: 1.0, Engine.COMPUTE: 0.9}, 10).faster is Engine.COMPUTE


def test_a_run_gives_every_node_its_engine_flag(capsys):
    scene = SCENES / "minimal.toml"
    plain = RunPlan(TWO_NODES, scene, 5, Path("out"), gpus={"left": 1})
    assert plain.node_args("front") == ()
    chosen = dataclasses.replace(plain, engine=Engine.COMPUTE)
    assert chosen.node_args("front") == ("--engine", "compute")
    assert chosen.node_args("left") == ("--gpu", "1", "--engine", "compute")
    drawn = dataclasses.replace(chosen, cave=Path("c.toml"), render_every=5)
    assert drawn.node_args("front")[-2:] == ("--engine", "compute")
    assert main(["node", "--wall", "front", "--engine", "cuda"]) == 2
    error = capsys.readouterr().err
    assert error.count("\n") == 1 and "--engine" in error and "'cuda'" in error


def test_the_compute_path_allocates_its_scratch_and_names_its_program(ctx):
    scene = make_scene(emitters=[FOUNTAIN], engine="compute")
    system = ParticleSystem(ctx, scene)
    assert system.engine is Engine.COMPUTE
    assert {"alive_masks", "offsets", "frame_counts"} <= set(system.resources)
    assert system.particle_program.extra["name"] == "particles/update_blocks.glsl"
    system.release()


def test_a_compute_frame_waits_once_its_checksum_bringing_the_live_count(ctx, monkeypatch):
    system = ParticleSystem(ctx, make_scene(emitters=[FOUNTAIN], engine="compute"))
    reads: list[int] = []
    for buffer in (system._checksum.result, system._passes.counts_buffer):
        real = buffer.read
        monkeypatch.setattr(buffer, "read", lambda *a, real=real, **k: reads.append(1) or
                            real(*a, **k), raising=False)
    rng = np.random.Generator(np.random.PCG64(3))
    for _ in range(20):
        system.step(FrameInput(DT, draw_transform(rng, system.scene.random_texture_size)))
        state = system.checksum()
        assert state.particles == system.live_count > 0
    assert len(reads) == 20  # one read per frame: digest and live count together
    system.release()


def test_draws_and_dispatches_flush_denormals_alike_on_this_context(ctx):
    assert probe(ctx), "the compute path would part from GS/TF at the first denormal"


@pytest.mark.slow
@pytest.mark.parametrize("name", ["dust_devil", "brownout"])
def test_both_paths_hold_the_same_bytes_for_500_frames(pair, name):
    both = pair(load_scene(SCENES / f"{name}.toml"))
    for _ in range(FRAMES):
        both.step()
    both.assert_same_bytes()
    emitters = both.gs_tf.read_emitters()
    emitted = int(emitters["serial"].sum() + emitters["count"].sum())
    assert both.counts[-1] > 20_000, "busy enough to mean something"
    assert both.counts[-1] < emitted, "and particles died along the way"


def test_emission_into_a_full_pool_drops_the_same_particles(pair):
    fountain = dict(FOUNTAIN, rate=9000.0, lifetime=[0.5, 0.6])
    both = pair(make_scene(emitters=[fountain, dict(fountain, name="second", rate=5000.0)],
                           capacity=1000))
    for _ in range(45):  # 233 new a frame: full in frame 5; from frame 31 on, room again
        both.step()
    both.assert_same_bytes()
    assert both.counts[:4] == [233, 466, 700, 933] and set(both.counts[4:]) == {1000}
    assert both.dropped[:4] == [0] * 4 and both.dropped[4] == 233 - 67  # room for 67 of 233
    assert set(both.dropped[5:30]) == {233, 234}, "full, nobody dead: all of a frame's new"


@pytest.mark.parametrize(("integrator", "tracer_method"),
                         [("rk4", None), ("etd2rk", None), ("etd2rk", "rk45")])
def test_tracers_mixed_with_inertial_classes_hold_the_same_bytes(pair, integrator,
                                                                  tracer_method):
    """Sand and smoke, a passive tracer class, from two fountains onto a ground: the per
    particle branch between integrator and tracer method gives both paths one state (with
    RK45, substeps held to a tolerance that makes the tracers divide their frames)."""
    sand = dict(FOUNTAIN, rate=300.0)
    smoke = dict(FOUNTAIN, name="smoke", particle_class="dust", rate=300.0)
    data = scene_dict(integrator=integrator, emitters=[sand, smoke],
                      collision={"kind": "plane", "height": 0.2, "friction": 0.3,
                                 "resilience": 0.5})
    if tracer_method is not None:
        data["simulation"] |= {"tracer_method": tracer_method, "tracer_tolerance": 1e-7}
    both = pair(parse_scene(with_smoke(data), name="tracers"))
    for _ in range(200):
        both.step()
    both.assert_same_bytes()
    classes = both.gs_tf.read_particles()["class_id"]
    assert (classes == 0).sum() > 100 and (classes == 1).sum() > 100
    if tracer_method is not None:
        counted = both.gs_tf.counters()
        assert counted == both.compute.counters() and counted["substeps_retaken"][0] > 0, \
            counted


def test_a_frame_with_more_emission_segments_than_one_dispatch_allows(pair):
    # max_emit is capped at the capacity: 4000 / 64 -> 63 batches x 2 emitters = 126 segments
    burst = dict(FOUNTAIN, rate=1e9)
    both = pair(make_scene(emitters=[burst, dict(burst, name="second")], capacity=4000))
    # as if the driver allowed 5 work groups per dispatch: the compute path's append and
    # the GS/TF splice each take more than one
    both.compute._passes._max_groups = both.gs_tf._passes._max_groups = 5
    for _ in range(3):
        both.step()
    both.assert_same_bytes()
    assert both.counts == [4000] * 3
    assert both.dropped == [4000, 8000, 8000], "past the first frame, all 8,000 new ones"


def test_frames_without_survivors_or_without_emission(pair):
    quiet = dict(FOUNTAIN, rate=0.0)  # an emitter that never emits: empty segments
    both = pair(make_scene(emitters=[quiet, dict(FOUNTAIN, name="pulse", rate=60.0)],
                           capacity=2000))
    dying = particle_cloud(1500, seed=3)
    dying["lifetime"] = DT / 2  # every one dead after one step
    for system in (both.gs_tf, both.compute):
        system.write_particles(dying)
    both.step()
    assert both.counts == [1], "no survivor; the pulse emitter's one new particle"
    assert both.dropped == [0]
    for _ in range(3):
        both.step()
    both.assert_same_bytes()


def test_runaway_and_expired_particles_go_and_an_empty_stream_stays_empty(pair):
    both = pair(make_scene(capacity=3000))  # no emitters: no emission at all
    cloud = particle_cloud(3000, seed=4)
    cloud["lifetime"] = np.repeat([DT / 2, 2.5 * DT, 1e6], 1000)
    index = np.arange(3000)
    runaway = index % 7 == 0
    cloud["vel"][runaway] = 1e38  # its step leaves the finite range: dropped, never stored
    for system in (both.gs_tf, both.compute):
        system.write_particles(cloud)
    for _ in range(4):
        both.step()
    both.assert_same_bytes()
    after_one, after_three = (int(np.sum(~runaway & (index >= n))) for n in (1000, 2000))
    assert both.counts == [after_one, after_one, after_three, after_three]
    cloud["lifetime"] = DT / 2
    for system in (both.gs_tf, both.compute):
        system.write_particles(cloud[:64])
    both.step()
    both.step()  # nothing live, nothing emitted
    assert both.counts[-2:] == [0, 0]
    both.assert_same_bytes()


@pytest.mark.slow
def test_a_mixed_cluster_agrees_frame_by_frame(tmp_path):
    """Walls on both paths in one lock-step run: the master compares every frame's
    checksums and finds no divergence."""
    engines = {"front": "gs_tf", "left": "compute", "right": "compute"}
    config = MasterConfig(tuple(engines), SCENES / "dust_devil.toml", 150,
                          f"mixed{os.getpid()}")
    plan = ClusterPlan(config, tmp_path, node_args={
        wall: ("--engine", engine) for wall, engine in engines.items()})
    record = run_cluster(plan)
    assert record.frames == 150 and record.agreed_at_the_end()
    assert record.divergences.total == 0 and record.resyncs.total == 0
    assert record.live_particles.max > 30_000
    for wall, engine in engines.items():
        assert f"engine path {engine}" in (tmp_path / "logs" / f"{wall}.log").read_text()
