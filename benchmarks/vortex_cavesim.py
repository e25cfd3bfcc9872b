"""cavesim's runs of the vortex case: both engine paths (RK4's tracer method) on a GL
context, and the numpy float32 twin on the CPU. Each step of an engine path ends in
`ctx.finish()` (glFinish) before its clock stops."""

from __future__ import annotations

from pathlib import Path

import moderngl
import numpy as np

from benchmarks.vortex_case import DT, NODES, STEPS, Run, position_errors, time_steps
from cavesim.core.fields.grid import save_field
from cavesim.core.frame import FrameInput
from cavesim.core.position import extended_position
from cavesim.core.records import PARTICLE_DTYPE
from cavesim.core.scene import parse_scene
from cavesim.core.scene.model import Engine, Scene
from cavesim.core.twin.system import TwinSystem
from cavesim.gpu.engine import ParticleSystem
from cavesim.tools.numerics.solid_body import BOX, solid_body, solid_body_grid

ENGINE_TOOLS = {Engine.GS_TF: "cavesim GS/TF", Engine.COMPUTE: "cavesim compute"}
TWIN_TOOL = "cavesim numpy float32 twin"
NO_DRAWS = np.eye(3, dtype=np.float32)  # the random texture's map: this scene draws nothing
# the engine's step is dt rounded to float32, so its particles are STEPS of those along
ELAPSED = STEPS * float(np.float32(DT))


def write_field(folder: Path) -> Path:
    """The vortex's NODES³ grid as a field file in `folder`."""
    path = folder / "solid_body.npz"
    save_field(path, solid_body_grid(NODES))
    return path


def vortex_scene(count: int, field_file: Path, engine: Engine) -> Scene:
    """One tracer class carried by the gridded vortex with RK4, room for `count`."""
    data = {
        "simulation": {"capacity": count, "seed": 1, "integrator": "rk4",
                       "engine": engine.value},
        "particle_class": [{"name": "smoke", "diameter": 1e-5, "motion": "tracer"}],
        "forces": {"drag": {}},  # what brings the flow into the particle pass
        "field": {"kind": "file", "file": str(field_file), "box_min": list(BOX[0]),
                  "box_max": list(BOX[1])},
    }
    return parse_scene(data, name="parcels_vortex")


def tracer_records(start: np.ndarray) -> np.ndarray:
    """Long-lived tracers at `start`, their velocity the flow there."""
    records = np.zeros(len(start), dtype=PARTICLE_DTYPE)
    records["pos"] = start
    records["vel"] = solid_body(start)
    records["lifetime"] = 1e6
    return records


def engine_run(ctx: moderngl.Context, field_file: Path, engine: Engine,
               start: np.ndarray) -> Run:
    system = ParticleSystem(ctx, vortex_scene(len(start), field_file, engine))
    try:
        system.write_particles(tracer_records(start))
        frame = FrameInput(DT, NO_DRAWS)

        def step() -> None:
            system.step(frame)
            ctx.finish()

        step_s, total_s = time_steps(step)
        end = extended_position(system.read_particles())
    finally:
        system.release()
    return _finished(ENGINE_TOOLS[engine], start, end, step_s, total_s)


def twin_run(field_file: Path, start: np.ndarray) -> Run:
    twin = TwinSystem(vortex_scene(len(start), field_file, Engine.GS_TF), np.float32)
    twin.write_particles(tracer_records(start))
    frame = FrameInput(DT, NO_DRAWS)
    step_s, total_s = time_steps(lambda: twin.step(frame))
    end = extended_position(twin.particles.records())
    return _finished(TWIN_TOOL, start, end, step_s, total_s)


def _finished(tool: str, start: np.ndarray, end: np.ndarray, step_s: float,
              total_s: float) -> Run:
    if len(end) != len(start):  # the rows would no longer pair up with their starts
        raise RuntimeError(f"{tool}: {len(end):,} of {len(start):,} particles left")
    rms, worst = position_errors(start, end, ELAPSED)
    return Run(tool, len(start), step_s, total_s, rms, worst)
