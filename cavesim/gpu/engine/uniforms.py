"""Uniform values of the engine's programs, computed once from the scene as float32 bits."""

from __future__ import annotations

from collections.abc import Mapping

import moderngl
import numpy as np

from cavesim.core.errors import ShaderError
from cavesim.core.features.collision import CollisionKind
from cavesim.core.fields.grid import FieldSeries
from cavesim.core.fields.heights import HeightGrid
from cavesim.core.fields.snapshot_time import FIRST_SNAPSHOT, FieldTime
from cavesim.core.helicopter.flight import ground_height
from cavesim.core.helicopter.inputs import FrameRotor
from cavesim.core.scene.model import Scene
from cavesim.core.substeps import stage_nodes, tableau
from cavesim.core.twin.dispersion import draw_moments


def physics_uniforms(scene: Scene, field: FieldSeries | None, ground: HeightGrid | None,
                     random: np.ndarray | None) -> dict[str, object]:
    """The particle pass's constants for the scene's compiled-in features (`random`: the
    random texture's words, where dispersion draws from it)."""
    values: dict[str, object] = {}
    forces = scene.forces
    if forces.gravity is not None:
        values["gravity"] = np.array(forces.gravity, dtype=np.float32)
    if forces.damping is not None:
        values["damping"] = np.float32(forces.damping)
    if forces.drag is not None:
        values["inv_tau"] = np.array(scene.inverse_relaxation_times(), dtype=np.float32)
        if any(scene.tracer_classes):  # uvec2: bit c of the 64 for class c
            bits = sum(1 << c for c, tracer in enumerate(scene.tracer_classes) if tracer)
            values["tracer_classes"] = np.array([bits & 0xFFFFFFFF, bits >> 32], dtype=np.uint32)
            if scene.tracers_take_substeps:
                values.update(adaptive_tracer_uniforms(scene))
        if any(scene.reynolds_per_speed()):  # vec4[(CLASS_COUNT + 3) / 4]: four a vec4
            per_class = np.array(scene.reynolds_per_speed(), dtype=np.float32)
            values["reynolds_per_speed"] = np.pad(per_class, (0, -len(per_class) % 4))
        if forces.dispersion is not None:
            values["mixing_length"] = np.float32(forces.dispersion.mixing_length)
            values.update(dispersion_uniforms(random))
        if field is not None:  # a grid, or a series of them
            values["field_box_min"] = np.array(field.first.box_min, dtype=np.float32)
            values["field_index_scale"] = field.first.index_scale
            if not field.steady:
                values["field_snapshots"] = np.int32(len(field.snapshots))
                values.update(field_time_uniforms(FIRST_SNAPSHOT))
        else:  # the rotor's downwash: its size and the ground it blows against
            values["rotor_radius"] = np.float32(scene.helicopter.rotor_radius)
            values["rotor_ground_z"] = np.float32(ground_height(scene))
    collision = scene.collision
    if collision is not None:
        values["friction"] = np.float32(collision.friction)
        values["resilience"] = np.float32(collision.resilience)
        values["friction_min_speed"] = np.float32(collision.friction_min_speed)
        if collision.kind is CollisionKind.PLANE:
            values["ground_z"] = np.float32(collision.height)
        else:
            values["ground_box_min"] = np.array(ground.box_min, dtype=np.float32)
            values["ground_index_scale"] = ground.index_scale
    return values


def adaptive_tracer_uniforms(scene: Scene) -> dict[str, object]:
    """Dormand-Prince's coefficients and the substeps' tolerance (cavesim.core.substeps)."""
    return {"rk45_tableau": tableau(np.float32), "rk45_nodes": stage_nodes(np.float32)[1:5],
            "tracer_tolerance": np.float32(scene.tracer_tolerance)}


def dispersion_uniforms(random: np.ndarray) -> dict[str, object]:
    """What standardises the dispersion's draws: their mean and spread over the texture."""
    mean, scale = draw_moments(random)
    return {"draw_mean": mean, "draw_scale": scale}


def rotor_uniforms(rotor: FrameRotor) -> dict[str, object]:
    """The downwash's per-frame uniforms (a helicopter scene's rotor this frame)."""
    return {"rotor_hub": rotor.hub, "induced_velocity": rotor.induced_velocity}


def field_time_uniforms(field_time: FieldTime) -> dict[str, object]:
    """A time-series field's per-frame uniforms: each stage's pair and weight."""
    return {"field_pair": np.array(field_time.pairs, dtype=np.int32),
            "field_weight": np.array(field_time.weights, dtype=np.float32)}


def write_uniforms(program: moderngl.Program, values: Mapping[str, object]) -> None:
    """Write each value's exact bytes to the uniform of that name in the program.

    A uniform its source declares but the compiler dropped (unused in this combination of
    features) is skipped; a name its source never declares is a ShaderError (a typo, or
    host and shader out of step). dtype decides the bits: float32 and uint32 go up as is.
    """
    unknown = sorted(set(values) - program.extra["declared"])
    if unknown:
        raise ShaderError(f"{program.extra['name']} declares no uniform {', '.join(unknown)}; "
                          f"it declares {', '.join(sorted(program.extra['declared']))}")
    for name, value in values.items():
        if (uniform := program.get(name, None)) is not None:
            uniform.write(np.ascontiguousarray(value).tobytes())
