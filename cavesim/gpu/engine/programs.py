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
from cavesim.core.features import registry
from cavesim.core.features.rules import Rule, glsl_checks, holds
from cavesim.core.limits import RANDOM_TEXTURE_SIZE_RANGE
from cavesim.core.records import EMITTER_WORDS, PARTICLE_VARYINGS, PARTICLE_WORDS
from cavesim.core.scene.model import Arithmetic, Scene
from cavesim.gpu.engine import counter_buffer
from cavesim.gpu.engine.counter_buffer import scene_counter_defines
from cavesim.gpu.shader_source import ProgramSpec

ARITHMETIC_IDS = {mode: number for number, mode in enumerate(Arithmetic)}  # arithmetic.glsl's
# What the particle pass counts, and where it may (cavesim/core/counters.py): a switch per
# row it combines into, on where the scene counts the row (and, on the GS/TF path, where its
# vertex stage may write storage), allowed where the row's `needs` hold
COUNTER_DEFINES: dict[str, tuple[int, ...]] = counter_buffer.DEFINES
COUNTER_RULES: tuple[Rule, ...] = counter_buffer.RULES
# Every define of the particle pass, with the values it may take (numbers: the extremes a
# scene may ask for): the base's and every feature's (`cavesim.core.features.registry`)
PASS_DEFINES: dict[str, tuple[int, ...]] = {**registry.PASS_DEFINES, **COUNTER_DEFINES}
PASS_RULES: tuple[Rule, ...] = (*registry.RULES, *COUNTER_RULES)
# pasted into the particle pass after its defines: the ids its conditions compare with,
# an #error for every combination no scene can make, and the counters' places in their buffer
PASS_PREAMBLE = "".join(f"#define {name} {number}\n" for name, number in registry.GLSL_IDS.items()
                        ) + glsl_checks(PASS_RULES) + counter_buffer.PREAMBLE
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
                              tuple(PASS_DEFINES), PARTICLE_VARYINGS, preamble=PASS_PREAMBLE)
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
                           (*PASS_DEFINES, *BLOCK_DEFINES), preamble=PASS_PREAMBLE)
SCAN = ProgramSpec("particles/scan.glsl", ("compute",), tuple(SCAN_DEFINES))
COMPACT = ProgramSpec("particles/compact.glsl", ("compute",), tuple(BLOCK_DEFINES))
APPEND = ProgramSpec("particles/append.glsl", ("compute",), tuple(EMISSION_FEATURES))
# the GS/TF path's move of the emission after the survivors (cavesim/gpu/engine/gs_tf.py)
SPLICE = ProgramSpec("particles/splice.glsl", ("compute",), tuple(BLOCK_DEFINES))


def physics_defines(scene: Scene) -> dict[str, int]:
    """The particle pass's defines (on either engine path): its features' and its counters'."""
    return {**registry.pass_defines(scene), **scene_counter_defines(scene)}


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
    """Whether a scene can give the particle pass `defines` (every one of PASS_DEFINES): the
    rules of its features and counters hold (`cavesim.core.features.rules`). The shader
    gate's cover holds every pair of values this allows together."""
    return holds(PASS_RULES, {**registry.IDS, **defines})


def particle_update_program(ctx: moderngl.Context, scene: Scene,
                            vertex_storage: bool = True) -> moderngl.Program:
    """The GS/TF particle pass; `vertex_storage` False where its vertex stage cannot write
    storage, and so counts nothing (`cavesim.gpu.engine.counter_buffer`)."""
    defines = physics_defines(scene)
    if not vertex_storage:
        defines |= dict.fromkeys(counter_buffer.SWITCHES, 0)
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

