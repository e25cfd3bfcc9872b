"""The gate's preprocessor, tested as plain text: which branch of each `#if` group a set of
defines takes (`cavesim.gpu.shader_conditionals`)."""

import pytest

from cavesim.core.errors import ShaderError
from cavesim.gpu.shader_conditionals import Conditionals, evaluate


def taken(text: str, **defines) -> list[str]:
    """The directives of the branches `defines` take, in text order."""
    conditionals = Conditionals(text)
    outcome = conditionals.taken(defines)
    return [b.directive for b in conditionals.branches if b in outcome.taken]


CHAIN = """\
#if MODE == 0
zero
#elif MODE == 1
one
#else
other
#endif
"""


@pytest.mark.parametrize("mode,branch", [(0, "#if MODE == 0"), (1, "#elif MODE == 1"),
                                         (7, "#else")])
def test_a_group_takes_its_first_branch_that_holds(mode, branch):
    assert taken(CHAIN, MODE=mode) == [branch]


def test_an_if_without_else_has_an_implied_branch_at_its_endif():
    text = "#if A\na\n#endif\n"
    (if_branch, implied) = Conditionals(text).branches
    assert implied.directive == "#endif (no branch of the #if at 0:1)"
    assert implied.where == "0:3" and implied.lines == 0 and if_branch.lines == 1
    assert taken(text, A=0) == [implied.directive]
    assert taken(text, A=1) == ["#if A"]


def test_macros_the_text_defines_are_expanded_in_conditions():
    text = """\
#define INTEGRATOR_EULER 0
#define INTEGRATOR_RK4 5
#define MODE_OF(x) x
#if INTEGRATOR == INTEGRATOR_RK4
rk4
#elif INTEGRATOR == INTEGRATOR_EULER
euler
#endif
"""
    assert taken(text, INTEGRATOR=5) == ["#if INTEGRATOR == INTEGRATOR_RK4"]
    assert taken(text, INTEGRATOR=0) == ["#elif INTEGRATOR == INTEGRATOR_EULER"]


def test_a_define_counts_only_in_a_branch_taken():
    # the shape of physics.glsl's COUNTS_EXITS_HERE: a macro defined either way, read later
    text = """\
#if COUNT && !defined GEOMETRY_SHADER
#define HERE 1
#else
#define HERE 0
#endif
#if HERE
counts
#endif
"""
    assert "#if HERE" in taken(text, COUNT=1, VERTEX_SHADER="")
    assert "#if HERE" not in taken(text, COUNT=1, GEOMETRY_SHADER="")
    assert "#if HERE" not in taken(text, COUNT=0, VERTEX_SHADER="")


def test_a_macro_defined_through_another_is_expanded_again():
    text = ("#define NATIVE 0\n#if !defined ARITHMETIC\n#define MODE NATIVE\n#else\n"
            "#define MODE ARITHMETIC\n#endif\n#if MODE == NATIVE\nnative\n#endif\n")
    assert "#if MODE == NATIVE" in taken(text, ARITHMETIC=0)
    assert "#if MODE == NATIVE" not in taken(text, ARITHMETIC=1)
    assert "#if MODE == NATIVE" in taken(text)


def test_the_given_defines_override_the_texts_own():
    # one variant's assembled text (its header's #defines) stands for every variant
    text = "#define HAS_DRAG 0\n#if HAS_DRAG\ndrag\n#endif\n"
    assert taken(text, HAS_DRAG=1) == ["#if HAS_DRAG"]
    assert taken(text) != ["#if HAS_DRAG"]


def test_ifdef_ifndef_undef_and_both_spellings_of_defined():
    text = """\
#define A
#ifdef A
a
#endif
#ifndef A
not a
#endif
#undef A
#if defined(A) || defined B
a or b
#endif
"""
    assert taken(text)[:1] == ["#ifdef A"]
    assert "#ifndef A" not in taken(text)
    assert "#if defined(A) || defined B" not in taken(text)
    assert "#if defined(A) || defined B" in taken(text, B=0)


def test_groups_inside_a_branch_not_taken_are_not_evaluated():
    text = "#if 0\n#if UNDEFINED_NAME\nx\n#endif\n#error never\n#endif\n"
    outcome = Conditionals(text).taken({})
    assert outcome.errors == () and len(outcome.taken) == 1  # the implied #else


def test_an_error_reached_is_reported_with_where_it_is():
    text = "#if HAS_TRACERS && !HAS_DRAG\n#error HAS_TRACERS needs HAS_DRAG\n#endif\n"
    assert Conditionals(text).taken({"HAS_TRACERS": 1, "HAS_DRAG": 1}).errors == ()
    (error,) = Conditionals(text).taken({"HAS_TRACERS": 1, "HAS_DRAG": 0}).errors
    assert error == "0:2: #error HAS_TRACERS needs HAS_DRAG"


def test_line_markers_name_the_file_and_line_of_each_branch():
    text = ("#version 430 core\n#define A 1\n#line 1 0\nmain\n#line 1 1\n\n#if A\n#else\n"
            "#line 4 1\n#endif\n#line 3 0\n#if A  // why\n#endif\n")
    branches = Conditionals(text, ("main.glsl", "include/lib.glsl")).branches
    assert [str(b) for b in branches] == [
        "include/lib.glsl:2 #if A", "include/lib.glsl:3 #else",
        "main.glsl:3 #if A", "main.glsl:4 #endif (no branch of the #if at main.glsl:3)"]


def test_comments_and_continued_lines_in_directives():
    text = "#if A /* one */ && \\\n    B  // two\nboth\n#endif  // done\n"
    assert taken(text, A=1, B=1) == ["#if A && B"]
    assert taken(text, A=1, B=0) == ["#endif (no branch of the #if at 0:1)"]
    assert Conditionals(text).branches[1].where == "0:4"


def test_source_lines_are_counted_in_the_branch_that_holds_them():
    text = "top\n#if A\none\ntwo\n#if B\nthree\n#endif\n\n#else\nfour\n#endif\n"
    conditionals = Conditionals(text)
    assert conditionals.lines == 5
    assert [(b.directive, b.lines) for b in conditionals.branches] == [
        ("#if A", 2), ("#if B", 1), ("#endif (no branch of the #if at 0:5)", 0), ("#else", 1)]


@pytest.mark.parametrize("expression,value", [
    ("1 + 2 * 3", 7), ("(1 + 2) * 3", 9), ("10 - 4 - 3", 3), ("2 << 3 >> 1", 8),
    ("7 / 2", 3), ("-7 / 2", -3), ("-7 % 2", -1), ("0x10 + 010", 24), ("4u == 4", 1),
    ("1 < 2 && 2 <= 2 && 3 > 2 && 3 >= 4", 0), ("1 == 1 || UNDEFINED", 1),
    ("0 && UNDEFINED", 0), ("!0 + !5", 1), ("~0", -1), ("6 & 3 | 8 ^ 1", 11),
    ("1 || 0 && 0", 1), ("X * 2 == 6", 1)])
def test_expressions_follow_glsl_precedence_and_c_division(expression, value):
    assert evaluate(expression, {"X": "3"}) == value


def test_a_macros_value_is_pasted_as_text_before_parsing():
    assert evaluate("TWO * 3", {"TWO": "1 + 1"}) == 4  # as in C: 1 + 1 * 3


@pytest.mark.parametrize("text,message", [
    ("#if UNDEFINED_NAME\n#endif\n", r"0:1 #if UNDEFINED_NAME: UNDEFINED_NAME is not defined"),
    ("#if F(1)\n#endif\n", "function-like macro F"),
    ("#if 1 / 0\n#endif\n", "division by zero"),
    ("#if (1\n#endif\n", r"a '\(' is not closed"),
    ("#if 1.5\n#endif\n", "cannot read"),
])
def test_a_condition_that_cannot_be_decided_is_an_error_naming_its_line(text, message):
    with pytest.raises(ShaderError, match=message):
        Conditionals("#define F(x) x\n" + text if "F(" in text else text).taken({})


@pytest.mark.parametrize("text,message", [
    ("#endif\n", "0:1: #endif without an open #if"),
    ("#if 1\n#else\n#else\n#endif\n", r"0:3: #else without an open #if \(after #else\)"),
    ("#if 1\n#else\n#elif 1\n#endif\n", "0:3: #elif without an open #if"),
    ("#if 1\n", "0:1: #if without #endif"),
    ("#if\n#endif\n", "0:1: #if without a condition"),
])
def test_unbalanced_groups_are_errors(text, message):
    with pytest.raises(ShaderError, match=message):
        Conditionals(text)
