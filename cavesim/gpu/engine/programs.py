"""Which shader code a scene gets: every program the engine builds and the `#define`s of each.

A feature the scene lacks is decided as 0 here, so its code is compiled out and the engine
allocates no texture, uniform or buffer for it (the test reads the generated source). The
same table tells the portability gate (`cavesim.gpu.shader_gate`) every program and the
values each of its defines can take.
"""

from __future__ import annotations

import itertools
from collections.abc import Iterator, Mapping

import moderngl

from cavesim.core.digest.shape import FOLD, WORDS_PER_THREAD, WORKGROUP_SIZE
from cavesim.core.emitters import EMIT_BATCH
from cavesim.core.features.collision import CollisionKind
from cavesim.core.limits import MAX_PARTICLE_CLASSES, RANDOM_TEXTURE_SIZE_RANGE
from cavesim.core.records import EMITTER_WORDS, PARTICLE_VARYINGS, PARTICLE_WORDS
from cavesim.core.scene.model import (
    Arithmetic,
    FieldInterpolation,
    FieldKind,
    FieldSampling,
    Integrator,
    OutOfDomain,
    Scene,
    TracerMethod,
)
from cavesim.gpu.shader_source import ProgramSpec

# Feature ids as the shaders spell them (#define COLLISION_PLANE 1 ... in
# shaders/include/physics.glsl, ARITHMETIC_PORTABLE in arithmetic.glsl); tests/gpu/test_features.py
# and tests/gpu/test_portable_physics.py hold the two sides together. An integrator's id is its
# `Integrator.gpu_id`, a tracer method's its `TracerMethod.gpu_id`
# (tests/unit/test_integrator_table.py).
ARITHMETIC_IDS = {Arithmetic.NATIVE: 0, Arithmetic.PORTABLE: 1}
COLLISION_IDS = {None: 0, CollisionKind.PLANE: 1, CollisionKind.HEIGHTFIELD: 2}
OUT_OF_DOMAIN_IDS = {OutOfDomain.CLAMP: 0, OutOfDomain.ZERO: 1}
SAMPLING_IDS = {FieldSampling.MANUAL: 0, FieldSampling.HARDWARE: 1}
INTERPOLATION_IDS = {FieldInterpolation.TRILINEAR: 0, FieldInterpolation.CATMULL_ROM: 1,
                     FieldInterpolation.BSPLINE: 2}


INTEGRATORS_BY_GPU_ID = {i.gpu_id: i for i in Integrator}

# The values each define can take (numbers: the extremes a scene may ask for).
PHYSICS_FEATURES: dict[str, tuple[int, ...]] = {
    "ARITHMETIC": tuple(ARITHMETIC_IDS.values()),
    "HAS_GRAVITY": (0, 1),
    "HAS_DRAG": (0, 1),
    "HAS_DAMPING": (0, 1),
    "COLLISION": tuple(COLLISION_IDS.values()),
    "INTEGRATOR": tuple(i.gpu_id for i in Integrator),
    "FIELD_OUT_OF_DOMAIN": tuple(OUT_OF_DOMAIN_IDS.values()),
    "FIELD_SAMPLING": tuple(SAMPLING_IDS.values()),
    "FIELD_IS_ROTOR": (0, 1),
    "FIELD_INTERPOLATION": tuple(INTERPOLATION_IDS.values()),
    "CLASS_COUNT": (1, MAX_PARTICLE_CLASSES),
}
# Drag beyond Stokes, dispersion (with the random texture's size it reads), a field given
# as a time series, the count of particles leaving a grid and passive tracer classes.
# TRACER_METHOD is the integrator's row's unless the scene steps its tracers adaptively
# (`reachable`).
TRANSPORT_FEATURES: dict[str, tuple[int, ...]] = {
    "HAS_SCHILLER_NAUMANN": (0, 1),
    "HAS_DISPERSION": (0, 1),
    "HAS_TRACERS": (0, 1),
    "TRACER_METHOD": tuple(m.gpu_id for m in TracerMethod),
    "FIELD_TIME_SERIES": (0, 1),
    "COUNT_DOMAIN_EXITS": (0, 1),
    "COUNT_TRACER_SUBSTEPS": (0, 1),
    "RANDOM_SIZE": RANDOM_TEXTURE_SIZE_RANGE,
}
EMISSION_FEATURES: dict[str, tuple[int, ...]] = {
    "ARITHMETIC": tuple(ARITHMETIC_IDS.values()),
    "RANDOM_SIZE": RANDOM_TEXTURE_SIZE_RANGE,
    "EMIT_BATCH": (EMIT_BATCH,),
    "FOLLOWING": (0, 1),
}
CHECKSUM_DEFINES = {"WORDS_PER_THREAD": WORDS_PER_THREAD,
                    "WORKGROUP_SIZE": WORKGROUP_SIZE, "FOLD": FOLD,
                    "PARTICLE_WORDS": PARTICLE_WORDS, "EMITTER_WORDS": EMITTER_WORDS}
# The compute path's work group sizes: blocks of 32 particles per invocation (its particle
# and compaction passes), and the one work group of its scan.
BLOCK_WORKGROUP_SIZE = 64
SCAN_SIZE = 256
BLOCK_DEFINES = {"WORKGROUP_SIZE": BLOCK_WORKGROUP_SIZE}
SCAN_DEFINES = {"SCAN_SIZE": SCAN_SIZE, "EMIT_BATCH": EMIT_BATCH}

PARTICLE_UPDATE = ProgramSpec("particles/update.glsl", ("vertex", "geometry"),
                              (*PHYSICS_FEATURES, *TRANSPORT_FEATURES), PARTICLE_VARYINGS)
EMITTER_UPDATE = ProgramSpec("particles/emitter_update.glsl", ("vertex",),
                             tuple(EMISSION_FEATURES), ("out_state",))
EMIT = ProgramSpec("particles/emit.glsl", ("vertex", "geometry"), tuple(EMISSION_FEATURES),
                   PARTICLE_VARYINGS)
CHECKSUM_SUMS = ProgramSpec("checksum/sums.glsl", ("compute",), tuple(CHECKSUM_DEFINES))
CHECKSUM_FOLD_PASS = ProgramSpec("checksum/fold.glsl", ("compute",),
                                 (*CHECKSUM_DEFINES, "LEVEL"))
CHECKSUM_DIGEST = ProgramSpec("checksum/digest.glsl", ("compute",), tuple(CHECKSUM_DEFINES))
CHECKSUM_PLAN = ProgramSpec("checksum/plan.glsl", ("compute",), tuple(CHECKSUM_DEFINES))
# the checksum's programs in the order of a frame (plan only when the GPU holds the counts)
CHECKSUM_PROGRAMS = (
    ("plan", CHECKSUM_PLAN, CHECKSUM_DEFINES),
    ("sums", CHECKSUM_SUMS, CHECKSUM_DEFINES),
    ("fold_1", CHECKSUM_FOLD_PASS, {**CHECKSUM_DEFINES, "LEVEL": 1}),
    ("fold_2", CHECKSUM_FOLD_PASS, {**CHECKSUM_DEFINES, "LEVEL": 2}),
    ("digest", CHECKSUM_DIGEST, CHECKSUM_DEFINES),
)
# the compute path's four passes (cavesim/gpu/engine/compute.py)
BLOCK_UPDATE = ProgramSpec("particles/update_blocks.glsl", ("compute",),
                           (*PHYSICS_FEATURES, *TRANSPORT_FEATURES, *BLOCK_DEFINES))
SCAN = ProgramSpec("particles/scan.glsl", ("compute",), tuple(SCAN_DEFINES))
COMPACT = ProgramSpec("particles/compact.glsl", ("compute",), tuple(BLOCK_DEFINES))
APPEND = ProgramSpec("particles/append.glsl", ("compute",), tuple(EMISSION_FEATURES))
# the GS/TF path's move of the emission after the survivors (cavesim/gpu/engine/gs_tf.py)
SPLICE = ProgramSpec("particles/splice.glsl", ("compute",), tuple(BLOCK_DEFINES))


def physics_defines(scene: Scene) -> dict[str, int]:
    """Feature switches of the particle pass (on either engine path)."""
    field = scene.field
    return {
        "ARITHMETIC": ARITHMETIC_IDS[scene.arithmetic],
        "HAS_GRAVITY": int(scene.forces.gravity is not None),
        "HAS_DRAG": int(scene.forces.drag is not None),
        "HAS_DAMPING": int(scene.forces.damping is not None),
        "COLLISION": COLLISION_IDS[scene.collision.kind if scene.collision else None],
        "INTEGRATOR": scene.integrator.gpu_id,
        "FIELD_OUT_OF_DOMAIN": OUT_OF_DOMAIN_IDS[field.out_of_domain] if field else 0,
        "FIELD_SAMPLING": SAMPLING_IDS[field.sampling] if field else 0,
        "FIELD_IS_ROTOR": int(field is not None and field.kind is FieldKind.ROTOR),
        # trilinear for a rotor and with hardware sampling: the scene loader sees to it
        "FIELD_INTERPOLATION": INTERPOLATION_IDS[field.interpolation] if field else 0,
        "CLASS_COUNT": max(1, len(scene.particle_classes)),
        "HAS_SCHILLER_NAUMANN": int(any(scene.reynolds_per_speed())),
        "HAS_DISPERSION": int(scene.forces.dispersion is not None),
        "HAS_TRACERS": int(any(scene.tracer_classes)),
        "TRACER_METHOD": scene.method_for_tracers.gpu_id,
        "FIELD_TIME_SERIES": int(scene.gridded_flow and field.times is not None),
        "COUNT_DOMAIN_EXITS": int(scene.gridded_flow),
        "COUNT_TRACER_SUBSTEPS": int(scene.tracers_take_substeps),
        "RANDOM_SIZE": scene.random_texture_size,
    }



def emission_defines(scene: Scene) -> dict[str, int]:
    """Sizes and arithmetic of the emitter programs."""
    return {
        "ARITHMETIC": ARITHMETIC_IDS[scene.arithmetic],
        "RANDOM_SIZE": scene.random_texture_size,
        "EMIT_BATCH": EMIT_BATCH,
        "FOLLOWING": int(any(e.follow_helicopter for e in scene.emitters)),
    }


def scene_programs(scene: Scene) -> list[tuple[ProgramSpec, dict[str, int]]]:
    """Every engine program a scene builds, with its defines."""
    physics = physics_defines(scene)
    programs = [(PARTICLE_UPDATE, physics), (BLOCK_UPDATE, {**physics, **BLOCK_DEFINES}),
                (SCAN, SCAN_DEFINES), (COMPACT, BLOCK_DEFINES),
                *((spec, defines) for _, spec, defines in CHECKSUM_PROGRAMS)]
    if scene.emitters:
        emission = emission_defines(scene)
        programs += [(EMITTER_UPDATE, emission), (EMIT, emission), (APPEND, emission),
                     (SPLICE, BLOCK_DEFINES)]
    return programs


def feature_combinations() -> Iterator[tuple[ProgramSpec, dict[str, int]]]:
    """Every engine program but the particle passes with every combination of the values its
    defines can take (a few each); the gate builds the particle passes in a cover of theirs
    (`cavesim.gpu.shader_gate`, over `valid_physics`)."""
    for spec in (EMITTER_UPDATE, EMIT, APPEND):
        for values in itertools.product(*EMISSION_FEATURES.values()):
            yield spec, dict(zip(EMISSION_FEATURES, values, strict=True))
    for spec, defines in ((SCAN, SCAN_DEFINES), (COMPACT, BLOCK_DEFINES), (SPLICE, BLOCK_DEFINES),
                          *((spec, defines) for _, spec, defines in CHECKSUM_PROGRAMS)):
        yield spec, dict(defines)


def valid_physics(defines: Mapping[str, int]) -> bool:
    """Whether a scene can give the particle pass `defines` (PHYSICS_FEATURES and
    TRANSPORT_FEATURES): `reachable` leaves them as they are, and the loader allows them:
    without drag there is no field, so every field define is 0; a field is not sampled by
    the texture unit in portable arithmetic. The shader gate's cover holds every pair of
    values this allows together."""
    field_free = ("FIELD_OUT_OF_DOMAIN", "FIELD_SAMPLING", "FIELD_IS_ROTOR")
    return (reachable(dict(defines)) == dict(defines)
            and (defines["HAS_DRAG"] or not any(defines[name] for name in field_free))
            and not (defines["ARITHMETIC"] == ARITHMETIC_IDS[Arithmetic.PORTABLE]
                     and defines["FIELD_SAMPLING"] == SAMPLING_IDS[FieldSampling.HARDWARE]))


def reachable(defines: dict[str, int]) -> dict[str, int]:
    """`defines` as `physics_defines` gives them: FIELD_INTERPOLATION selects code only for a
    grid sampled by hand (drag, no rotor, manual), and is trilinear (0) otherwise; only a
    grid is a time series or counts exits; drag laws beyond Stokes and dispersion need
    drag, dispersion a ground too, tracers drag and no dispersion (physics.glsl's
    #errors); TRACER_METHOD is the integrator's unless the tracers step adaptively, and only
    they count substeps."""
    out = dict(defines)
    if not out["HAS_DRAG"] or out["FIELD_IS_ROTOR"]:
        out["FIELD_TIME_SERIES"] = out["COUNT_DOMAIN_EXITS"] = 0
    grid = (out["HAS_DRAG"] and not out["FIELD_IS_ROTOR"]
            and out["FIELD_SAMPLING"] == SAMPLING_IDS[FieldSampling.MANUAL])
    if not grid:
        out["FIELD_INTERPOLATION"] = 0
    if not out["HAS_DRAG"]:
        out["HAS_SCHILLER_NAUMANN"] = out["HAS_DISPERSION"] = 0
    if out["COLLISION"] == COLLISION_IDS[None]:
        out["HAS_DISPERSION"] = 0
    if not out["HAS_DRAG"] or out["HAS_DISPERSION"]:
        out["HAS_TRACERS"] = 0
    if not out["HAS_TRACERS"] or out["TRACER_METHOD"] != TracerMethod.RK45.gpu_id:
        out["TRACER_METHOD"] = INTEGRATORS_BY_GPU_ID[out["INTEGRATOR"]].tracer_method.gpu_id
        out["COUNT_TRACER_SUBSTEPS"] = 0
    return out


def particle_update_program(ctx: moderngl.Context, scene: Scene,
                            vertex_storage: bool = True) -> moderngl.Program:
    """The GS/TF particle pass; `vertex_storage` False where its vertex stage cannot write
    storage, and so counts nothing (`cavesim.gpu.engine.frame_counts`)."""
    defines = physics_defines(scene)
    defines["COUNT_DOMAIN_EXITS"] &= int(vertex_storage)
    defines["COUNT_TRACER_SUBSTEPS"] &= int(vertex_storage)
    return PARTICLE_UPDATE.build(ctx, defines)


def emitter_update_program(ctx: moderngl.Context, scene: Scene) -> moderngl.Program:
    return EMITTER_UPDATE.build(ctx, emission_defines(scene))


def emit_program(ctx: moderngl.Context, scene: Scene) -> moderngl.Program:
    return EMIT.build(ctx, emission_defines(scene))


def checksum_programs(ctx: moderngl.Context) -> dict[str, moderngl.ComputeShader]:
    """The checksum's passes by name: plan, sums, fold_1, fold_2, digest."""
    return {name: spec.build(ctx, defines) for name, spec, defines in CHECKSUM_PROGRAMS}


def block_update_program(ctx: moderngl.Context, scene: Scene) -> moderngl.ComputeShader:
    return BLOCK_UPDATE.build(ctx, {**physics_defines(scene), **BLOCK_DEFINES})


def scan_program(ctx: moderngl.Context) -> moderngl.ComputeShader:
    return SCAN.build(ctx, SCAN_DEFINES)


def compact_program(ctx: moderngl.Context) -> moderngl.ComputeShader:
    return COMPACT.build(ctx, BLOCK_DEFINES)


def append_program(ctx: moderngl.Context, scene: Scene) -> moderngl.ComputeShader:
    return APPEND.build(ctx, emission_defines(scene))


def splice_program(ctx: moderngl.Context) -> moderngl.ComputeShader:
    return SPLICE.build(ctx, BLOCK_DEFINES)

