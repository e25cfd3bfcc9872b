"""Which shader code a scene gets: the `#define`s of each program, from the scene's features.

A feature the scene lacks is decided as 0 here, so its code is compiled out and the engine
allocates no texture, uniform or buffer for it (the test reads the generated source).
"""

from __future__ import annotations

import moderngl

from cavesim.engine.layout import PARTICLE_VARYINGS
from cavesim.scene.model import (
    CollisionKind,
    FieldKind,
    FieldSampling,
    Integrator,
    OutOfDomain,
    Scene,
)
from cavesim.shader_source import build_program

INTEGRATOR_IDS = {integrator: i for i, integrator in enumerate(Integrator)}
COLLISION_IDS = {None: 0, CollisionKind.PLANE: 1, CollisionKind.HEIGHTFIELD: 2}
OUT_OF_DOMAIN_IDS = {OutOfDomain.CLAMP: 0, OutOfDomain.ZERO: 1}
SAMPLING_IDS = {FieldSampling.MANUAL: 0, FieldSampling.HARDWARE: 1}

EMIT_BATCH = 64  # particles per GS invocation: 64 x 10 components fits the GL minimum of 1024
CHECKSUM_WORKGROUP_SIZE = 64
CHECKSUM_WORDS_PER_THREAD = 256  # 10M words (1M particles) leave 313 KB of sums to read

PHYSICS_DEFINES = ("HAS_GRAVITY", "HAS_DRAG", "HAS_DAMPING", "COLLISION", "INTEGRATOR",
                   "FIELD_OUT_OF_DOMAIN", "FIELD_SAMPLING", "FIELD_IS_ROTOR", "CLASS_COUNT")
EMISSION_DEFINES = ("EMITTER_COUNT", "RANDOM_SIZE", "EMIT_BATCH", "FOLLOWING")


def physics_defines(scene: Scene) -> dict[str, int]:
    """Feature switches of the particle pass (and of its compute-shader twin)."""
    field = scene.field
    return {
        "HAS_GRAVITY": int(scene.forces.gravity is not None),
        "HAS_DRAG": int(scene.forces.drag is not None),
        "HAS_DAMPING": int(scene.forces.damping is not None),
        "COLLISION": COLLISION_IDS[scene.collision.kind if scene.collision else None],
        "INTEGRATOR": INTEGRATOR_IDS[scene.integrator],
        "FIELD_OUT_OF_DOMAIN": OUT_OF_DOMAIN_IDS[field.out_of_domain] if field else 0,
        "FIELD_SAMPLING": SAMPLING_IDS[field.sampling] if field else 0,
        "FIELD_IS_ROTOR": int(field is not None and field.kind is FieldKind.ROTOR),
        "CLASS_COUNT": max(1, len(scene.particle_classes)),
    }


def emission_defines(scene: Scene) -> dict[str, int]:
    """Sizes of the emitter programs."""
    return {
        "EMITTER_COUNT": len(scene.emitters),
        "RANDOM_SIZE": scene.random_texture_size,
        "EMIT_BATCH": EMIT_BATCH,
        "FOLLOWING": int(any(e.follow_helicopter for e in scene.emitters)),
    }


def particle_update_program(ctx: moderngl.Context, scene: Scene) -> moderngl.Program:
    return build_program(ctx, "particles/update.glsl", ("vertex", "geometry"),
                         physics_defines(scene), PHYSICS_DEFINES, varyings=PARTICLE_VARYINGS)


def in_place_update_program(ctx: moderngl.Context, scene: Scene) -> moderngl.ComputeShader:
    return build_program(ctx, "particles/update_in_place.glsl", ("compute",),
                         physics_defines(scene), PHYSICS_DEFINES)


def emitter_update_program(ctx: moderngl.Context, scene: Scene) -> moderngl.Program:
    return build_program(ctx, "particles/emitter_update.glsl", ("vertex",),
                         emission_defines(scene), EMISSION_DEFINES, varyings=("out_state",))


def emit_program(ctx: moderngl.Context, scene: Scene) -> moderngl.Program:
    return build_program(ctx, "particles/emit.glsl", ("vertex", "geometry"),
                         emission_defines(scene), EMISSION_DEFINES, varyings=PARTICLE_VARYINGS)


def checksum_program(ctx: moderngl.Context) -> moderngl.ComputeShader:
    return build_program(ctx, "checksum/checksum.glsl", ("compute",),
                         {"WORDS_PER_THREAD": CHECKSUM_WORDS_PER_THREAD,
                          "WORKGROUP_SIZE": CHECKSUM_WORKGROUP_SIZE},
                         ("WORDS_PER_THREAD", "WORKGROUP_SIZE"))
