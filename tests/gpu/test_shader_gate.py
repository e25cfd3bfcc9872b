"""The portability gate: every program cavesim can build passes the Khronos reference
front-end (glslangValidator), a lint for what NVIDIA rejects, and this GL context; the
particle passes in a few hundred variants at most that cover every pair of feature values
and every #if branch, native and portable, and every scene shipped or under tests/."""

import dataclasses
import importlib.util
import random
import re
from pathlib import Path
from types import SimpleNamespace

import pytest

from cavesim.core.errors import ShaderError
from cavesim.core.features.registry import IDS
from cavesim.core.features.rules import holds
from cavesim.core.limits import MAX_PARTICLE_CLASSES
from cavesim.core.scene import Arithmetic
from cavesim.gpu import shader_gate
from cavesim.gpu.covering_array import pairs
from cavesim.gpu.engine.programs import (
    ARITHMETIC_IDS,
    BLOCK_DEFINES,
    BLOCK_UPDATE,
    PARTICLE_UPDATE,
    PASS_DEFINES,
    PASS_RULES,
    physics_defines,
    valid_physics,
)
from cavesim.gpu.gate_cover import FEATURES, PASSES, particle_cover
from cavesim.gpu.gl import context
from cavesim.gpu.gl.arithmetic_probe import ARITHMETIC_PROBE
from cavesim.gpu.render.programs import DUST
from cavesim.gpu.shader_conditionals import Conditionals
from cavesim.gpu.shader_gate import (
    Build,
    Finding,
    all_builds,
    check_on_context,
    check_sources,
    context_builds,
    lint,
    load_scenes,
    main,
    scene_cover,
    scene_files,
    summary,
    uniform_components,
)
from cavesim.gpu.shader_source import SHADER_ROOT, ProgramSpec, ShaderSource

ROOT = Path(__file__).parents[2]
SCENES = ROOT / "config" / "scenes"
NATIVE, PORTABLE = ARITHMETIC_IDS[Arithmetic.NATIVE], ARITHMETIC_IDS[Arithmetic.PORTABLE]
FIXTURES = Path(__file__).parents[1] / "glsl_fixtures"
# scenes other tests write from a module constant: (module, constant)
WRITTEN_SCENES = {"full": ("tests/unit/test_scene.py", "FULL_TOML"),
                  "overflow": ("tests/processes/test_capacity_drops_run.py", "SCENE"),
                  "pulsing": ("tests/processes/test_flow_file_run.py", "SCENE")}
MOST_VARIANTS = 400  # per engine path


def written_scenes(folder: Path) -> list[Path]:
    """The scene files other tests write, written into `folder`."""
    paths = []
    for name, (module_path, constant) in WRITTEN_SCENES.items():
        spec = importlib.util.spec_from_file_location(f"_gate_{name}", ROOT / module_path)
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        (path := folder / f"{name}.toml").write_text(getattr(module, constant))
        paths.append(path)
    return paths


pytestmark = pytest.mark.xdist_group("shader_gate")  # the cover and its builds, made once

@pytest.fixture(scope="module")
def scenes(tmp_path_factory):
    return load_scenes([*scene_files(), *written_scenes(tmp_path_factory.mktemp("scenes"))])


@pytest.fixture(scope="module")
def cover(scenes):
    return scene_cover(scenes)


@pytest.fixture(scope="module")
def builds(scenes, cover):
    return all_builds(scenes, cover)


def sample(count: int, seed: int = 7) -> list[dict[str, int]]:
    """Valid combinations of the particle pass's defines drawn at random, each once."""
    draw, found = random.Random(seed), {}
    while len(found) < count:
        row = {name: draw.choice(values) for name, values in FEATURES.items()}
        if valid_physics(row):
            found[tuple(row.items())] = row
    return list(found.values())


def test_each_engine_path_builds_the_particle_pass_in_at_most_400_variants(cover, builds):
    for spec in PASSES:
        variants = [dict(b.defines) for b in builds if b.spec == spec]
        assert len(variants) == len(cover.rows) <= MOST_VARIANTS
        assert {d["ARITHMETIC"] for d in variants} == {NATIVE, PORTABLE}
    assert all(valid_physics(row) for row in cover.rows)
    compiled = context_builds(builds)
    native = [b for b in builds if b.spec in PASSES and dict(b.defines)["ARITHMETIC"] == NATIVE]
    assert all(b in compiled for b in native)
    assert not any(dict(b.defines)["ARITHMETIC"] == PORTABLE for b in compiled
                   if b.spec in PASSES)
    assert any(dict(b.defines).get("CLASS_COUNT") == MAX_PARTICLE_CLASSES
               for b in builds if b.spec == DUST)


def test_the_gate_covers_the_arithmetic_probe_in_both_modes(builds):
    modes = {dict(b.defines)["ARITHMETIC"] for b in builds if b.spec == ARITHMETIC_PROBE}
    assert modes == {0, 1}


def test_every_scene_shipped_or_under_tests_is_built_as_it_is(scenes, builds):
    files = scene_files()
    assert set(SCENES.glob("*.toml")) | set((ROOT / "tests" / "data" / "logs").glob("*.toml")) \
        <= set(files)
    assert {"full", "overflow", "pulsing", "smoke", "downwash_portable"} <= set(scenes)
    built = {(b.spec, b.defines) for b in builds}
    for name, scene in scenes.items():
        physics = physics_defines(scene)
        for spec, fixed in PASSES.items():
            assert (spec, tuple(sorted({**physics, **fixed}.items()))) in built, name
    origins = {build.origin for build in builds}  # a scene another's twin is built once
    assert {f"scene {path.stem}" for path in SCENES.glob("*.toml")} | {"probe"} <= origins


def test_every_pair_of_values_a_valid_combination_holds_is_in_a_variant(cover):
    assert cover.uncovered == []
    held = {pair for row in sample(500) for pair in pairs(row, tuple(FEATURES))}
    assert held <= set(cover.pairs.required)
    assert not held & set(cover.pairs.excluded)
    # the features' rules and their #errors, found by the search
    assert (("ARITHMETIC", PORTABLE), ("FIELD_SAMPLING", 1)) in cover.pairs.excluded
    assert (("HAS_TRACERS", 1), ("HAS_DISPERSION", 1)) in cover.pairs.excluded
    assert (("FIELD_INTERPOLATION", 2), ("FIELD_TIME_SERIES", 1)) in cover.pairs.required


def test_every_branch_a_valid_combination_takes_is_taken_native_and_portable(cover):
    assert {(s.program, s.stage, s.arithmetic) for s in cover.stages} == {
        (spec.name, stage, mode) for spec in PASSES for stage in spec.stages
        for mode in ("native", "portable")}
    for stage in cover.stages:
        assert stage.missed == [] and stage.taken == stage.reachable, str(stage)
        assert len(stage.reachable) > 100
    assert cover.errors == ()
    # what the shaders refuse, or compile only in another stage or arithmetic, is told apart
    unreachable = {(s.stage, s.arithmetic): s.unreachable for s in cover.stages}
    unknown = "#error unknown INTEGRATOR"
    (where,) = [f"{path.relative_to(SHADER_ROOT)}:{lines.index(unknown)}"  # the #else above
                for path in sorted((SHADER_ROOT / "include").glob("*.glsl"))
                if unknown in (lines := path.read_text().splitlines())]
    assert all(has(found, where, "#else") for found in unreachable.values())
    counting = "#if COUNTING && !defined GEOMETRY_SHADER"
    assert has(unreachable["geometry", "native"], "include/counters.glsl", counting)
    assert not has(unreachable["vertex", "native"], "include/counters.glsl", counting)
    hardware = "#if FIELD_SAMPLING == SAMPLING_HARDWARE"
    assert has(unreachable["compute", "portable"], "include/field.glsl", hardware)
    assert not has(unreachable["compute", "native"], "include/field.glsl", hardware)


def has(branches, where: str, directive: str) -> bool:
    """Whether a branch of `directive` at `where` (a file, or file:line) is among these."""
    return any(b.directive == directive and f"{b.where}:".startswith(f"{where}:")
               for b in branches)


def test_no_valid_combination_takes_a_branch_called_unreachable(cover):
    stages = [(spec, stage, Conditionals(source.text, source.files)) for spec, fixed in
              PASSES.items() for stage, source in spec.sources({**cover.rows[0],
                                                                  **fixed}).items()]
    reachable = {(s.program, s.stage, s.arithmetic): s.reachable for s in cover.stages}
    mode = {NATIVE: "native", PORTABLE: "portable"}
    for row in sample(150, seed=11):
        for spec, stage, conditionals in stages:
            outcome = conditionals.taken({**row, **PASSES[spec]})
            assert outcome.errors == ()
            assert outcome.taken <= reachable[spec.name, stage, mode[row["ARITHMETIC"]]], row


def test_a_validity_that_refuses_a_scene_is_caught(scenes):
    rows = {name: physics_defines(scene) for name, scene in scenes.items()}

    def without_adaptive_tracers(defines):
        return valid_physics(defines) and defines["TRACER_METHOD"] != 4

    with pytest.raises(ValueError, match="not valid by the predicate without_adaptive_tracers"):
        particle_cover(rows, without_adaptive_tracers)


def test_a_validity_that_lets_through_what_the_shaders_refuse_is_caught(scenes):
    rows = {name: physics_defines(scene) for name, scene in scenes.items()}

    def forgets_the_ground(defines):  # dispersion, a census without a ground: rules' #errors
        return valid_physics({**defines, "COLLISION": 1})

    cover = particle_cover(rows, forgets_the_ground)
    assert cover.errors and all("needs COLLISION is not COLLISION_NONE" in e
                                for e in cover.errors)
    assert any("#error HAS_DISPERSION" in e for e in cover.errors)


@pytest.mark.slow
def test_the_searches_find_what_every_valid_combination_holds_and_takes(cover):
    """Slow (a search over every combination the rule table allows, for every pair of
    values, and 3,000 valid rows through the preprocessor): the only test that holds the
    pair search to the whole product, and the branches called unreachable to a large
    sample."""
    assert set(exact_pairs()) == set(cover.pairs.required)
    rows = sample(3000, seed=13)
    stages = [(spec, stage, Conditionals(source.text, source.files)) for spec, fixed in
              PASSES.items() for stage, source in spec.sources({**rows[0], **fixed}).items()]
    reachable = {(s.program, s.stage, s.arithmetic): s.reachable for s in cover.stages}
    mode = {NATIVE: "native", PORTABLE: "portable"}
    for row in rows:
        for spec, stage, conditionals in stages:
            outcome = conditionals.taken({**row, **PASSES[spec]})
            assert outcome.taken <= reachable[spec.name, stage, mode[row["ARITHMETIC"]]], row


def exact_pairs() -> list[tuple]:
    """Every pair of values some combination of the defines keeping every rule holds, by a
    search that checks each rule as soon as the names it reads have values: the truth the
    cover's search from a sample is held to."""
    names = list(FEATURES)
    reads = {rule: {n for n in names if re.search(rf"\b{n}\b", rule.subject + " " + rule.needs)}
             for rule in PASS_RULES}
    position = {name: k for k, name in enumerate(names)}
    due = {k: tuple(r for r in PASS_RULES if max(position[n] for n in reads[r]) == k)
           for k in range(len(names))}

    def exists(fixed: dict[str, int], row: dict[str, int], k: int) -> bool:
        if k == len(names):
            return True
        name = names[k]
        for value in (fixed[name],) if name in fixed else FEATURES[name]:
            row[name] = value
            if holds(due[k], row) and exists(fixed, row, k + 1):
                return True
        del row[name]
        return False

    return [pair for pair in pairs_of_all_values() if exists(dict(pair), dict(IDS), 0)]


def pairs_of_all_values() -> list[tuple]:
    names = list(FEATURES)
    return [((a, x), (b, y)) for i, a in enumerate(names) for b in names[i + 1:]
            for x in FEATURES[a] for y in FEATURES[b]]


def test_the_summary_says_what_is_covered_without_compiling(scenes, cover, builds, capsys):
    lines = summary(scenes, cover, builds)
    assert lines[0] == f"variants per path: {len(cover.rows)}"
    text = "\n".join(lines)
    assert f"value pairs covered: {len(cover.pairs.required)} of {len(cover.pairs.required)}" \
        in text
    assert "branches a valid combination takes and no variant does: 0" in text
    assert "particles/update_blocks.glsl compute portable: " in text
    assert f"scenes included: {len(scenes)} (" in text
    assert main(["--summary"]) == 0
    printed = capsys.readouterr().out
    assert printed.startswith("variants per path: ") and "builds in all: " in printed


def test_the_gate_prints_a_line_a_finding_and_fails(monkeypatch, capsys, cover, builds):
    finding = Finding(builds[0], "vertex", "ERROR: particles/update.glsl:3: bad")
    monkeypatch.setattr(shader_gate, "scene_cover", lambda scenes: cover)  # computed once
    monkeypatch.setattr(shader_gate, "check_sources", lambda found: [finding])
    monkeypatch.setattr(shader_gate, "check_on_context", lambda ctx, found: [])
    monkeypatch.setattr(context, "create_context", lambda: SimpleNamespace(release=lambda: None))
    assert main([]) == 1
    assert capsys.readouterr().out.splitlines()[-1] == str(finding)


def test_scene_files_are_the_shipped_ones_and_those_under_tests(tmp_path):
    (shipped := tmp_path / "scenes").mkdir()
    (logs := tmp_path / "tests" / "data").mkdir(parents=True)
    (shipped / "a.toml").write_text('name = "a"\n')
    (logs / "b.toml").write_text('name = "b"\n[simulation]\nseed = 1\n')
    (logs / "cave.toml").write_text('name = "x"\n[[wall]]\nname = "front"\n')  # no scene
    assert scene_files(shipped, tmp_path / "tests") == [shipped / "a.toml", logs / "b.toml"]
    assert scene_files(shipped, tmp_path / "nowhere") == [shipped / "a.toml"]


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
    defines = dict.fromkeys(PASS_DEFINES, 0) | {"CLASS_COUNT": 1, "RANDOM_SIZE": 16}
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
    defines = dict.fromkeys(PASS_DEFINES, 0) | {
        "HAS_DRAG": 1, "CLASS_COUNT": 64, "RANDOM_SIZE": 16}
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
