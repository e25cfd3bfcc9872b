"""The frame's counters on the GPU (cavesim/core/counters.py, cavesim/gpu/engine/
counter_buffer.py): in native arithmetic equal to the float64 twin's on both engine paths,
every frame, in a scene whose counts hang on no rounding (the portable scenes hold every
counter to the portable twin's bits: tests/gpu/test_portable_physics.py); not counted by
GS/TF where its vertex stage may not write storage, its copied drops still counted and its
bytes unchanged; and the defines and layout the table generates."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from scenes import FOUNTAIN, SAND, SMOKE, particle_cloud

from cavesim.core.counters import COUNTERS, counted_rows
from cavesim.core.frame import FrameInput
from cavesim.core.scene import Engine, parse_scene
from cavesim.core.scene.model import ENGINE_PATHS
from cavesim.core.twin.system import TwinSystem
from cavesim.gpu.engine import ParticleSystem, counter_buffer, gs_tf
from cavesim.gpu.engine.programs import PARTICLE_UPDATE, physics_defines, valid_physics

DT = 1 / 60
FLOW = 1.5  # m/s along x: a tracer moves 0.025 m a frame
TRACERS = 200
FRAMES = 60
IDENTITY = np.eye(3, dtype=np.float32)


def crossing_scene(**simulation):
    """Smoke carried by a uniform flow through the box's +x face, and a fountain of sand in
    the middle of the box (gone long before it could leave it) that overflows the capacity.
    No gravity: only the flow moves anything."""
    data = {"simulation": {"capacity": 300, "seed": 3, "integrator": "rk4",
                           "random_texture_size": 64, "tracer_method": "rk45", **simulation},
            "particle_class": [SAND, SMOKE],
            "emitter": [dict(FOUNTAIN, position=[0.0, 0.0, 2.0], rate=900.0, speed=1.0,
                             speed_spread=0.2, lifetime=[0.1, 0.15])],
            "forces": {"drag": {}},
            "field": {"kind": "uniform", "box_min": [-4.0, -4.0, 0.0],
                      "box_max": [4.0, 4.0, 4.0], "resolution": [2, 2, 2],
                      "params": {"velocity": [FLOW, 0.0, 0.0]}}}
    return parse_scene(data, name="crossing")


def smoke_crossing() -> np.ndarray:
    """TRACERS smoke particles, tracer j half a step before the face at frame j % 40: a
    step takes it across in mid-flight, far from any rounding."""
    records = particle_cloud(TRACERS, seed=5)
    steps = np.arange(TRACERS) % 40 + 0.5
    records["pos"][:, 0] = 4.0 - steps * FLOW * DT
    records["vel"] = (FLOW, 0.0, 0.0)
    records["class_id"] = 1
    return records


def test_native_counters_are_the_float64_twins_on_both_paths(ctx):
    scene = crossing_scene()
    twin = TwinSystem(scene, np.float64)
    gpus = {engine: ParticleSystem(ctx, dataclasses.replace(scene, engine=engine))
            for engine in ENGINE_PATHS}
    start = smoke_crossing()
    totals = {}
    try:
        for system in (twin, *gpus.values()):
            system.write_particles(start)
        for k in range(1, FRAMES + 1):
            frame = FrameInput(DT, IDENTITY)
            twin.step(frame)
            expected = twin.counters()
            for engine, gpu in gpus.items():
                gpu.step(frame)
                gpu.checksum()
                assert gpu.counters() == expected, f"frame {k}, {engine.value} path"
            for name, values in expected.items():
                totals[name] = np.add(totals.get(name, 0), values)
    finally:
        for gpu in gpus.values():
            gpu.release()
    assert set(expected) == {row.name for row in COUNTERS} - {"ground_deposits"}  # no ground
    assert totals["domain_exits"].tolist() == [0, TRACERS], "every tracer, once; no sand"
    assert totals["capacity_drops"][0] > 0 and totals["tracers_stepped"][0] == FRAMES * TRACERS
    assert totals["substeps_retaken"][0] == 0 and expected["most_substeps"] == (1,)


def test_without_vertex_storage_gs_tf_counts_only_the_copied_rows_and_steps_the_same_bytes(
        ctx, monkeypatch):
    scene = dataclasses.replace(crossing_scene(), engine=Engine.GS_TF)
    counting = ParticleSystem(ctx, scene)
    monkeypatch.setattr(counter_buffer, "stage_counts", lambda engine, info: False)
    monkeypatch.setattr(gs_tf, "stage_counts", lambda engine, info: False)
    silent = ParticleSystem(ctx, scene)
    try:
        for system in (counting, silent):
            system.write_particles(smoke_crossing())
        for k in range(1, 30):
            for system in (counting, silent):
                system.step(FrameInput(DT, IDENTITY))
            assert silent.checksum() == counting.checksum(), f"frame {k}: counting changed bytes"
            assert silent.counters() == {"capacity_drops": counting.counters()["capacity_drops"]}
    finally:
        counting.release()
        silent.release()


def test_each_row_the_pass_counts_has_a_switch_and_its_constant_offset():
    scene = crossing_scene()
    defines = physics_defines(scene)
    assert {name: defines[name] for name in counter_buffer.SWITCHES} == {
        "COUNT_DOMAIN_EXITS": 1, "COUNT_TRACERS_STEPPED": 1, "COUNT_SUBSTEPS_TAKEN": 1,
        "COUNT_SUBSTEPS_RETAKEN": 1, "COUNT_MOST_SUBSTEPS": 1, "COUNT_GROUND_DEPOSITS": 0}
    assert valid_physics(defines), "the switches keep the rows' rules"
    assert not valid_physics({**defines, "HAS_TRACERS": 0}), "substeps need tracers"
    source = PARTICLE_UPDATE.sources(defines)["vertex"].text
    # room for 64 classes of exits, then one uint each; the copied drops after them
    for define in ("#define COUNTING (COUNT_DOMAIN_EXITS || COUNT_TRACERS_STEPPED || ",
                   "#define DOMAIN_EXITS_AT 0\n", "#define TRACERS_STEPPED_AT 64\n",
                   "#define SUBSTEPS_TAKEN_AT 65\n", "#define SUBSTEPS_RETAKEN_AT 66\n",
                   "#define MOST_SUBSTEPS_AT 67\n",
                   "count_add(DOMAIN_EXITS_AT + int(", "count_max(MOST_SUBSTEPS_AT, taken)"):
        assert define in source, define
    assert "#error COUNT_DOMAIN_EXITS needs HAS_DRAG" in source


@pytest.mark.parametrize("simulation", [{"tracer_method": "rk4"}, {}])
def test_a_scene_counts_only_the_rows_its_features_have(simulation):
    scene = crossing_scene(**simulation)
    rows = {row.name for row in counted_rows(scene)}
    substeps = {"tracers_stepped", "substeps_taken", "substeps_retaken", "most_substeps"}
    assert rows == {"domain_exits", "capacity_drops"} | (substeps if simulation == {} else
                                                         set())
    defines = physics_defines(scene)
    assert all(defines[f"COUNT_{name.upper()}"] == (name in rows) for name in substeps)


def settling_scene(engine: str = "gs_tf", resilience: float = 0.0,
                   arithmetic: str = "native"):
    """Sand dropped from rest onto a plane, no air: it lands at the time a fall takes."""
    data = {"simulation": {"capacity": 400, "seed": 3, "integrator": "semi_implicit_euler",
                           "random_texture_size": 64, "engine": engine,
                           "arithmetic": arithmetic},
            "particle_class": [SAND], "forces": {"gravity": [0.0, 0.0, -9.81]},
            "collision": {"kind": "plane", "friction": 0.5, "resilience": resilience,
                          "height": 0.0}}
    return parse_scene(data, name="settling")


def sand_at_rest(heights: np.ndarray) -> np.ndarray:
    records = particle_cloud(len(heights), seed=9)
    records["pos"][:, 2] = heights
    records["vel"] = 0.0
    records["class_id"] = 0
    return records


@pytest.mark.parametrize(("resilience", "arithmetic"), [(0.0, "native"), (0.4, "portable")])
def test_the_sand_on_the_ground_is_counted_as_it_settles_on_both_paths(ctx, resilience,
                                                                        arithmetic):
    """ground_deposits, a level: each frame, the particles that live on and lie on the
    ground. Sand from rest at heights h lands after sqrt(2 h / g); once landed without a
    bounce it stays counted every frame. Both paths count what the twin does: the float64
    one's where the sand settles at once, the portable one's (the GPU's bits) where it
    bounces, and a bounce's height hangs on the last bit."""
    heights = np.linspace(0.05, 2.0, 300)
    twin = TwinSystem(settling_scene(resilience=resilience, arithmetic=arithmetic))
    gpus = [ParticleSystem(ctx, settling_scene(engine.value, resilience, arithmetic))
            for engine in ENGINE_PATHS]
    counted = []
    try:
        for system in (twin, *gpus):
            system.write_particles(sand_at_rest(heights))
        for k in range(1, 46):
            frame = FrameInput(DT, IDENTITY)
            twin.step(frame)
            for gpu in gpus:
                gpu.step(frame)
                gpu.checksum()
                assert gpu.counters()["ground_deposits"] == \
                    twin.counters()["ground_deposits"], f"frame {k}"
            counted.append(twin.counters()["ground_deposits"][0])
    finally:
        for gpu in gpus:
            gpu.release()
    landed = [int((np.sqrt(2 * heights / 9.81) < k * DT).sum()) for k in range(1, 46)]
    if resilience == 0.0:  # settled for good: within a frame's fall of the closed form
        assert all(a <= b for a, b in zip(counted, counted[1:], strict=False))
        assert all(abs(c - n) <= 12 for c, n in zip(counted, landed, strict=True))
        assert counted[-1] == 300
    else:  # bouncing: fewer lie on the ground than have reached it
        assert 0 < counted[-1] < landed[-1]
