"""The portability gate: every program cavesim can build passes the Khronos reference
front-end (glslangValidator), a lint for what NVIDIA rejects, and this GL context."""

import dataclasses
from pathlib import Path

import pytest

from cavesim.core.errors import ShaderError
from cavesim.core.limits import MAX_PARTICLE_CLASSES
from cavesim.core.scene import Arithmetic, Integrator
from cavesim.gpu.engine.programs import (
    ARITHMETIC_IDS,
    BLOCK_DEFINES,
    BLOCK_UPDATE,
    PARTICLE_UPDATE,
    PHYSICS_FEATURES,
    TRANSPORT_FEATURES,
)
from cavesim.gpu.render.programs import DUST
from cavesim.gpu.shader_gate import (
    Build,
    all_builds,
    check_on_context,
    check_sources,
    context_builds,
    lint,
    uniform_components,
)
from cavesim.gpu.shader_source import ProgramSpec, ShaderSource

SCENES = Path(__file__).parents[2] / "config" / "scenes"
NATIVE, PORTABLE = ARITHMETIC_IDS[Arithmetic.NATIVE], ARITHMETIC_IDS[Arithmetic.PORTABLE]
FIXTURES = Path(__file__).parents[1] / "glsl_fixtures"


@pytest.fixture(scope="module")
def builds():
    return all_builds(SCENES)


def test_the_gate_covers_every_scene_and_every_feature_combination(builds):
    origins = {build.origin for build in builds}
    assert {f"scene {path.stem}" for path in SCENES.glob("*.toml")} | {"probe"} <= origins
    physics = [b for b in builds if b.spec == PARTICLE_UPDATE]
    native = [b for b in physics if dict(b.defines)["ARITHMETIC"] == NATIVE]
    portable = [dict(b.defines) for b in physics if dict(b.defines)["ARITHMETIC"] == PORTABLE]
    combinations = 1
    for name, values in PHYSICS_FEATURES.items():
        combinations *= len(values) if name not in ("ARITHMETIC", "FIELD_INTERPOLATION") else 1
    assert combinations >= 2 * 2 * 2 * 3 * len(Integrator) * 2 * 2 * 2 * 2
    # the product, and the two cubic interpolations where they are compiled in: with drag
    # from a grid sampled by hand, 1/8 of it; plus the scenes' own class counts
    assert len(native) >= combinations * (1 + 2 / 8)
    cubic = [d for b in native if (d := dict(b.defines))["FIELD_INTERPOLATION"]]
    assert all(d["HAS_DRAG"] and not d["FIELD_IS_ROTOR"] and not d["FIELD_SAMPLING"]
               for d in cubic)
    gpu_ids = {i.gpu_id for i in Integrator}
    assert {dict(b.defines)["INTEGRATOR"] for b in native} == gpu_ids
    # portable: each integrator with every other feature at each of its values
    for integrator in gpu_ids:
        for name, values in PHYSICS_FEATURES.items():
            if name not in ("ARITHMETIC", "FIELD_SAMPLING", "INTEGRATOR"):
                seen = {d[name] for d in portable if d["INTEGRATOR"] == integrator}
                assert seen == set(values), (integrator, name)
    compiled = context_builds(builds)
    assert all(b in compiled for b in native)
    assert not any(dict(b.defines)["ARITHMETIC"] == PORTABLE for b in compiled
                   if b.spec in (PARTICLE_UPDATE, BLOCK_UPDATE))
    assert any(dict(b.defines).get("CLASS_COUNT") == MAX_PARTICLE_CLASSES
               for b in builds if b.spec == DUST)


@pytest.mark.slow
@pytest.mark.requires("glslang")
def test_every_program_passes_the_reference_front_end_and_the_lint(builds):
    findings = check_sources(builds)
    assert findings == [], "\n".join(map(str, findings[:10]))


@pytest.mark.slow
def test_every_program_compiles_on_this_context_within_gl43_uniform_limits(ctx, builds):
    findings = check_on_context(ctx, context_builds(builds))
    assert findings == [], "\n".join(map(str, findings[:10]))


class EndsWithLine(ProgramSpec):
    """A program as the assembler wrote them before NVIDIA was tried: a `#line` last."""

    def variant_sources(self, variants):
        return [{stage: dataclasses.replace(source, text=source.text + "#line 48 0\n")
                 for stage, source in sources.items()}
                for sources in super().variant_sources(variants)]


@pytest.mark.requires("glslang")
def test_the_gate_fails_a_program_that_ends_with_a_line_directive():
    spec = EndsWithLine(**{f.name: getattr(PARTICLE_UPDATE, f.name)
                           for f in dataclasses.fields(ProgramSpec)})
    defines = dict.fromkeys((*PHYSICS_FEATURES, *TRANSPORT_FEATURES), 0) | {"CLASS_COUNT": 1}
    build = Build(spec, tuple(sorted(defines.items())), "test")
    findings = check_sources([build])
    assert {f.stage for f in findings} == {"vertex", "geometry"}
    assert all("C0115" in f.message and "'#line 48 0'" in f.message for f in findings)
    assert str(findings[0]).startswith("particles/update.glsl [ARITHMETIC=0, CLASS_COUNT=1, "
                                       "COLLISION=0")


def test_lint_passes_what_the_assembler_writes():
    assert lint(ShaderSource("#version 430 core\nvoid main() {}\n#endif\n", ("a.glsl",))) == []
    assert lint(ShaderSource("void main() {}\n  #  line 3 1\n\n", ("a.glsl",)))


@pytest.mark.requires("glslang")
def test_reference_front_end_errors_name_the_included_file_and_line():
    spec = ProgramSpec("gl/program.glsl", ("vertex", "fragment"), root=FIXTURES)
    (finding,) = check_sources([Build(spec, (), "test")])
    assert finding.stage == "fragment"
    assert finding.message.startswith("ERROR: gl/broken_helper.glsl:3:")


@pytest.mark.requires("glslang")
def test_reference_front_end_catches_what_llvmpipe_lets_through(tmp_path, ctx):
    # an implicit uint -> int conversion: GLSL forbids it, glslang and NVIDIA reject it
    (tmp_path / "lax.glsl").write_text(
        "#if defined COMPUTE_SHADER\nlayout(local_size_x = 1) in;\n"
        "void main() { int x = 1u; }\n#endif\n")
    spec = ProgramSpec("lax.glsl", ("compute",), root=tmp_path)
    (finding,) = check_sources([Build(spec, (), "test")])
    assert "lax.glsl:3: '=' :  cannot convert" in finding.message


def test_a_missing_validator_is_named_with_its_package():
    with pytest.raises(ShaderError, match=r"no-such-validator not found: install the Debian "
                                          r"package glslang-tools"):
        check_sources([], validator="no-such-validator")


def test_uniform_components_count_each_array_element_as_a_vec4(ctx):
    # inv_tau[CLASS_COUNT] and dt: 64 elements + 1 float, each a vec4 slot
    defines = dict.fromkeys((*PHYSICS_FEATURES, *TRANSPORT_FEATURES), 0) | {
        "HAS_DRAG": 1, "CLASS_COUNT": 64}
    program = BLOCK_UPDATE.build(ctx, defines | BLOCK_DEFINES)
    try:
        assert uniform_components(program) >= 4 * 64 + 4
    finally:
        program.release()


def test_context_check_names_a_program_over_the_gl43_uniform_budget(tmp_path, ctx):
    (tmp_path / "wide.glsl").write_text(
        "#if defined COMPUTE_SHADER\nlayout(local_size_x = 1) in;\n"
        "layout(std430, binding = 0) buffer Out { float o[]; };\nuniform float w[200];\n"
        "void main() { o[0] = w[int(gl_GlobalInvocationID.x)]; }\n#endif\n")
    (finding,) = check_on_context(ctx, [Build(ProgramSpec("wide.glsl", ("compute",),
                                                          root=tmp_path), (), "test")])
    assert "800 uniform components" in finding.message and "512" in finding.message
