"""The shader source assembler, tested as plain text; one test compiles through Mesa."""

import math
import re
from pathlib import Path

import moderngl
import pytest

from cavesim.core.errors import ShaderError
from cavesim.gpu.gl.context import REQUIRED_GL_VERSION
from cavesim.gpu.shader_source import MAX_INCLUDE_DEPTH, ShaderSource, assemble, build_program

FIXTURES = Path(__file__).parents[1] / "glsl_fixtures"


def lines(name, stage="vertex", defines=None, allowed=None, root=FIXTURES):
    """The assembled text of a fixture as a list of lines."""
    defines = {} if defines is None else defines
    allowed = set(defines) if allowed is None else allowed
    return assemble(name, stage, defines, allowed, root).text.splitlines()


def define_value(name, value):
    """The literal the assembler writes for `#define name value`."""
    prefix = f"#define {name} "
    (line,) = [x for x in lines("lib/inner.glsl", defines={name: value}) if x.startswith(prefix)]
    return line.removeprefix(prefix)


def test_version_then_defines_then_stage_then_line_marker():
    assert lines("stages.glsl", "fragment", {"SPEED": 1.5}) == [
        "#version 430 core",
        "#define SPEED 1.5",
        "#define FRAGMENT_SHADER",
        "#line 1 0",
        "float speed() { return SPEED; }",
        "#if defined FRAGMENT_SHADER",
        "out vec4 color;",
        "#endif",
    ]


def test_version_is_the_gl_version_the_context_requires():
    assert lines("lib/inner.glsl")[0] == f"#version {REQUIRED_GL_VERSION} core"


@pytest.mark.parametrize("name", ["stages.glsl", "include_last.glsl", "empty.glsl"])
def test_no_program_ends_with_a_line_marker(name):
    # NVIDIA: "error C0115: #line source-string number invalid" when a `#line` is last
    assert not lines(name)[-1].startswith("#line")


@pytest.mark.parametrize(
    ("stage", "macro"),
    [("vertex", "VERTEX_SHADER"), ("geometry", "GEOMETRY_SHADER"), ("compute", "COMPUTE_SHADER")],
)
def test_each_stage_defines_its_macro(stage, macro):
    assert lines("lib/inner.glsl", stage)[1] == f"#define {macro}"


def test_unknown_stage_names_value_and_allowed_stages():
    with pytest.raises(
        ShaderError,
        match=r"'compute', 'fragment', 'geometry', 'vertex'\], got stage='tessellation'",
    ):
        lines("lib/inner.glsl", "tessellation")


def test_defines_sorted_and_false_kept_as_zero():
    text = lines("lib/inner.glsl", defines={"ZETA": 3, "ALPHA": False, "MID": True})
    assert text[1:4] == ["#define ALPHA 0", "#define MID 1", "#define ZETA 3"]


def test_unknown_define_rejected_listing_allowed():
    with pytest.raises(ShaderError, match=r"unknown defines \['TYPO'\]; allowed: \['SPEED'\]"):
        lines("lib/inner.glsl", defines={"SPEED": 1.0, "TYPO": 1}, allowed={"SPEED"})


def test_missing_allowed_define_rejected():
    with pytest.raises(ShaderError, match=r"defines \['WIND'\] missing"):
        lines("lib/inner.glsl", defines={"SPEED": 1.0}, allowed={"SPEED", "WIND"})


def test_allowed_given_as_a_string_rejected():
    with pytest.raises(ShaderError, match="not a string"):
        lines("lib/inner.glsl", defines={"SPEED": 1.0}, allowed="SPEED")


@pytest.mark.parametrize(
    "name", ["lower", "1ABC", "A-B", "_A", "GL_RESERVED", "A__B", "VERTEX_SHADER"]
)
def test_bad_define_names_rejected(name):
    with pytest.raises(ShaderError, match=r"define names must match .*" + repr(name)):
        lines("lib/inner.glsl", defines={name: 1})


@pytest.mark.parametrize("value", [math.nan, math.inf, -math.inf, 1e39])
def test_non_finite_or_out_of_float32_range_rejected(value):
    with pytest.raises(ShaderError, match=r"X must be a finite float32 value"):
        define_value("X", value)


@pytest.mark.parametrize("value", [2**31, -(2**31) - 1])
def test_int_outside_int32_rejected(value):
    with pytest.raises(ShaderError, match=rf"X must fit a 32-bit GLSL int, got {value}"):
        define_value("X", value)


@pytest.mark.parametrize("value", ["1.0", None, 1j])
def test_other_value_types_rejected(value):
    with pytest.raises(
        ShaderError, match=rf"must be bool, int or float, got {type(value).__name__}"
    ):
        define_value("X", value)


@pytest.mark.parametrize("value", [1e-6, 0.1, 3.0, -2.5e10, 1 / 3, 1e16, -0.0, 6.2831853])
def test_float_literal_reads_back_exactly(value):
    literal = define_value("X", value)
    assert "." in literal or "e" in literal, f"{literal!r} would read as a GLSL int"
    assert float(literal) == value
    assert math.copysign(1.0, float(literal)) == math.copysign(1.0, value)


def test_int_literal_is_decimal():
    assert define_value("X", -17) == "-17"


def test_include_pasted_between_line_markers():
    source = assemble("include_one.glsl", "vertex", {}, set(), FIXTURES)
    assert source.files == ("include_one.glsl", "lib/common.glsl")
    assert source.text.splitlines()[2:] == [
        "#line 1 0",
        "// uses the common helpers",
        "#line 1 1",
        "const float TAU = 6.2831853;",
        "float twice(float x) { return 2.0 * x; }",
        "#line 3 0",
        "void main() {}",
    ]


def test_nested_includes_relative_and_root_absolute():
    source = assemble("nested.glsl", "vertex", {}, set(), FIXTURES)
    assert source.files == ("nested.glsl", "lib/outer.glsl", "lib/inner.glsl", "lib/common.glsl")
    assert source.text.splitlines()[2:] == [
        "#line 1 0",
        "#line 1 1",
        "#line 1 2",
        "float inner() { return 1.0; }",
        "#line 2 1",
        "#line 1 3",
        "const float TAU = 6.2831853;",
        "float twice(float x) { return 2.0 * x; }",
        "#line 3 1",
        "float outer() { return inner(); }",
        "#line 2 0",
        "void main() {}",
    ]


def test_position_restated_after_each_conditional_branch():
    # The compiler skips `#line` in an inactive group: only the marker after `#else` or
    # `#endif` puts "void main" back on line 6 when the include sits in the skipped branch.
    text = lines("include_in_stage_block.glsl")
    assert text[text.index("#else") + 1] == "#line 4 0"
    assert text[text.index("#endif") + 1] == "#line 6 0"


def test_include_cycle_shows_the_chain():
    with pytest.raises(
        ShaderError,
        match=r"cycle_b.glsl:2: #include cycle: cycle_a.glsl -> cycle_b.glsl -> cycle_a.glsl",
    ):
        lines("cycle_a.glsl")


def include_chain(root, length):
    """Write f0.glsl including f1.glsl ... including f{length}.glsl into `root`."""
    for i in range(length):
        (root / f"f{i}.glsl").write_text(f'#include "f{i + 1}.glsl"\n')
    (root / f"f{length}.glsl").write_text("float leaf;\n")


def test_include_depth_limit(tmp_path):
    include_chain(tmp_path, MAX_INCLUDE_DEPTH)
    assert "float leaf;" in lines("f0.glsl", root=tmp_path)

    include_chain(tmp_path, MAX_INCLUDE_DEPTH + 1)
    with pytest.raises(ShaderError, match=rf"nested deeper than {MAX_INCLUDE_DEPTH}: f0.glsl"):
        lines("f0.glsl", root=tmp_path)


def test_missing_include_names_including_file_and_line():
    with pytest.raises(
        ShaderError, match=r"missing_include.glsl:3: #include 'lib/no_such_file.glsl' not found"
    ):
        lines("missing_include.glsl")


def test_missing_main_file_names_root():
    with pytest.raises(ShaderError, match=r"shader 'nope.glsl' not found under .*glsl_fixtures"):
        lines("nope.glsl")


def test_include_leaving_the_root_rejected():
    with pytest.raises(ShaderError, match=r"escapes_root.glsl:1: '../outside.glsl' leaves the"):
        lines("escapes_root.glsl")


def test_shader_name_leaving_the_root_rejected():
    with pytest.raises(ShaderError, match=r"shader: '../stages.glsl' leaves the shader root"):
        lines("../stages.glsl")


def test_pragma_once_pastes_once_and_other_files_twice():
    source = assemble("once.glsl", "vertex", {}, set(), FIXTURES)
    text = source.text.splitlines()
    assert source.files == ("once.glsl", "lib/once_lib.glsl", "lib/inner.glsl")
    assert text.count("struct Particle { vec3 p; };") == 1
    assert "// include 'lib/once_lib.glsl': pasted already (#pragma once)" in text
    assert '#include "' not in source.text  # moderngl would try to paste it, even in a comment
    assert text.count("float inner() { return 1.0; }") == 2
    assert text.count("#line 1 2") == 2


def test_source_defining_an_injected_name_rejected():
    with pytest.raises(ShaderError, match=r"conflict.glsl:2: #define SPEED conflicts"):
        lines("conflict.glsl", defines={"SPEED": 1.0})


def test_source_defining_a_stage_macro_rejected():
    with pytest.raises(ShaderError, match=r"conflict_stage.glsl:1: #define VERTEX_SHADER"):
        lines("conflict_stage.glsl", "fragment")


def test_source_with_version_rejected():
    with pytest.raises(ShaderError, match=r"has_version.glsl:1: remove #version"):
        lines("has_version.glsl")


def test_explain_maps_source_numbers_to_files():
    source = ShaderSource(text="", files=("main.glsl", "lib/noise.glsl"))
    log = (
        "0:12(3): error: `x' undeclared\n"
        "1:4(20): error: syntax error, unexpected '}'\n"
        "ERROR: 1:7: 'y' : undeclared identifier\n"
        "7:1(1): error: source number not ours\n"
    )
    assert source.explain(log) == (
        "main.glsl:12(3): error: `x' undeclared\n"
        "lib/noise.glsl:4(20): error: syntax error, unexpected '}'\n"
        "ERROR: lib/noise.glsl:7: 'y' : undeclared identifier\n"
        "7:1(1): error: source number not ours\n"
    )


def test_compile_error_in_include_names_file_and_line(ctx):
    # the session's context (tests/conftest.py): a second context in one process would
    # become current and take the session's over
    with pytest.raises(ShaderError) as raised:
        build_program(ctx, "gl/program.glsl", ["vertex", "fragment"], {}, set(), root=FIXTURES)
    message = str(raised.value)
    assert message.startswith("gl/program.glsl (fragment stage): ")
    assert re.search(r"gl/broken_helper\.glsl:3\b", message), message
    assert isinstance(raised.value.__cause__, moderngl.Error)
