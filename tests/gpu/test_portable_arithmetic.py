"""Portable arithmetic (include/arithmetic.glsl): on this context every function gives the
bits of the float32 numpy twin, whatever the hardware does with subnormals; division,
square root and the three operations are correctly rounded with the documented flush;
the transcendental functions keep their stated accuracy; the portable shader uses nothing
whose precision the GLSL spec leaves open, and passes the reference front-end."""

import json
import math
import os
import re
import subprocess
import sys
from fractions import Fraction
from pathlib import Path

import numpy as np
import pytest
from portable_operands import SPECIALS, operands

from cavesim.core import portable
from cavesim.core.errors import ShaderError
from cavesim.core.portable.ulp_bounds import ACCURACY, measure, ulp_error
from cavesim.gpu.gl.arithmetic_probe import (
    ARITHMETIC_PROBE,
    FUNCTIONS,
    probe_defines,
    run_function,
    twin_results,
)
from cavesim.gpu.shader_gate import Build, check_sources
from cavesim.gpu.shader_source import SHADER_ROOT, ProgramSpec
from cavesim.tools.bench.arithmetic_cost import call_costs, table

ROOT = Path(__file__).parents[2]
INCLUDE = SHADER_ROOT / "include"


def arithmetic_text() -> str:
    """include/arithmetic.glsl with the portable parts it includes pasted in their place."""
    return re.sub(r'#include "(portable_\w+\.glsl)"\n',
                  lambda m: (INCLUDE / m[1]).read_text().replace("#pragma once\n", ""),
                  (INCLUDE / "arithmetic.glsl").read_text())
SCALAR_CORE = ("f_add", "f_sub", "f_mul", "f_div", "f_sqrt", "f_exp", "f_log", "f_pow",
               "f_sin", "f_cos", "f_mix", "f_dot vec3", "f_normalize vec3")
QUIET_NAN = 0x7FC00000


def bits(values):
    return np.asarray(values, dtype=np.float32).view(np.uint32)


def differences(function, cases, gpu, twin):
    """The first differing cases, readable: operands and both results in hex."""
    differing = np.nonzero((bits(gpu) != bits(twin)).any(axis=1))[0]
    rows = [f"{function}: {len(differing)} of {len(cases)} cases differ"]
    for n in differing[:8]:
        rows.append(f"  a={[hex(v) for v in bits(cases[n, 0])]} "
                    f"b={[hex(v) for v in bits(cases[n, 1])]} "
                    f"c={[hex(v) for v in bits(cases[n, 2])]} "
                    f"gpu={[hex(v) for v in bits(gpu[n])]} twin={[hex(v) for v in bits(twin[n])]}")
    return "\n".join(rows)


# --- the same bits as the twin ---------------------------------------------------------

@pytest.mark.parametrize("function", FUNCTIONS)
def test_every_function_gives_the_twins_bits(ctx, function):
    count = 2**21 if function in SCALAR_CORE else 2**17
    cases = operands(function, count, seed=FUNCTIONS.index(function))
    gpu = run_function(ctx, function, cases)
    twin = twin_results(function, cases)
    assert (bits(gpu) == bits(twin)).all(), differences(function, cases, gpu, twin)


KEPT_DENORMALS_RUN = """
import json, sys
import numpy as np
sys.path.insert(0, "tests/support")
from portable_operands import operands
from cavesim.gpu.gl.arithmetic_probe import FUNCTIONS, run_function, twin_results
from cavesim.gpu.gl.context import create_context
ctx = create_context()
report = {}
for function in FUNCTIONS:
    cases = operands(function, 2**14, seed=7)
    gpu = run_function(ctx, function, cases, keep_denormals=True)
    twin = twin_results(function, cases)
    report[function] = int((gpu.view(np.uint32) != twin.view(np.uint32)).any(axis=1).sum())
tiny = np.zeros((1, 3, 3), np.float32)
tiny[0, 0, 0], tiny[0, 1, 0] = 2.0**-70, 2.0**-70
report["native product"] = float(run_function(ctx, "f_mul", tiny, "native", True)[0, 0])
report["renderer"] = ctx.info["GL_RENDERER"]
print(json.dumps(report))
"""


@pytest.mark.slow
def test_the_bits_do_not_depend_on_whether_the_hardware_flushes_subnormals():
    # llvmpipe runs the engine's dispatches with FTZ and DAZ set; with LP_NUM_THREADS=0 and
    # the mode left alone, a dispatch keeps subnormals, as some GPUs do (a GPU keeps or
    # flushes them as it does: the bits must be the twin's either way)
    path = os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))
    env = os.environ | {"LP_NUM_THREADS": "0", "PYTHONPATH": path}
    result = subprocess.run([sys.executable, "-c", KEPT_DENORMALS_RUN], cwd=ROOT, env=env,
                            capture_output=True, text=True, timeout=600, check=False)
    assert result.returncode == 0, result.stderr[-3000:]
    report = json.loads(result.stdout.splitlines()[-1])
    kept = report.pop("native product") == 2.0**-140
    assert kept or "llvmpipe" not in report.pop("renderer"), "llvmpipe flushed: no test"
    report.pop("renderer", None)
    assert report == dict.fromkeys(FUNCTIONS, 0)


# --- correctly rounded, with the documented flush --------------------------------------

def exact(value):
    """A float32 operand as the portable functions read it (subnormals as zero)."""
    return Fraction(0) if (int(bits(value)) & 0x7F800000) == 0 else Fraction(float(value))


def rounded(value: Fraction, negative: bool = False) -> int:
    """The float32 bits the definition gives an exact value: round to nearest even to 24
    bits with an unbounded exponent, a zero of its sign below 2^-126, inf from 2^128."""
    sign = 0x80000000 if value < 0 or (value == 0 and negative) else 0
    value = abs(value)
    if value == 0:
        return sign
    exponent = value.numerator.bit_length() - value.denominator.bit_length()
    if Fraction(2) ** exponent > value:
        exponent -= 1
    significand = round(value / Fraction(2) ** (exponent - 23))  # half to even
    if significand == 2**24:
        significand, exponent = 2**23, exponent + 1
    if exponent < -126:
        return sign
    if exponent > 127:
        return sign | 0x7F800000
    return sign | ((exponent + 127) << 23) | (significand - 2**23)


def rounded_root(value: Fraction) -> int:
    """The float32 bits of sqrt(value), rounded to nearest even from the exact root."""
    shift = 120  # value 4^shift is an integer of >= 52 bits for every float32
    scaled = value * Fraction(4) ** shift
    assert scaled.denominator == 1
    root = math.isqrt(scaled.numerator)
    dropped = root.bit_length() - 24
    kept, rest = root >> dropped, root & ((1 << dropped) - 1)
    half = 1 << (dropped - 1)
    inexact = root * root != scaled.numerator
    if rest > half or (rest == half and (inexact or kept & 1)):
        kept += 1
    return rounded(Fraction(kept << dropped, 2**shift))


def finite_cases(function, count):
    cases = operands(function, count, seed=11)
    return cases[np.isfinite(cases[:, 0, 0]) & np.isfinite(cases[:, 1, 0])]


EXACT = {
    "f_add": lambda a, b: rounded(exact(a) + exact(b), exact(a) + exact(b) == 0 and
                                  bool(np.signbit(a)) and bool(np.signbit(b))),
    "f_sub": lambda a, b: rounded(exact(a) - exact(b), exact(a) - exact(b) == 0 and
                                  bool(np.signbit(a)) and not np.signbit(b)),
    "f_mul": lambda a, b: rounded(exact(a) * exact(b), bool(np.signbit(a) ^ np.signbit(b))),
    "f_div": lambda a, b: rounded(exact(a) / exact(b), bool(np.signbit(a) ^ np.signbit(b))),
    "f_sqrt": lambda a, b: rounded_root(exact(a)),
}


@pytest.mark.parametrize("function", EXACT)
def test_the_operations_division_and_root_are_correctly_rounded_and_flushed(ctx, function):
    cases = finite_cases(function, 2**16)
    if function == "f_div":  # x / 0 and sqrt(x <= 0): test_special_values
        cases = cases[[exact(b) != 0 for b in cases[:, 1, 0]]]
    if function == "f_sqrt":
        cases = cases[[exact(a) > 0 for a in cases[:, 0, 0]]]
    a, b = cases[:, 0, 0], cases[:, 1, 0]
    got = bits(run_function(ctx, function, cases)[:, 0])
    expected = np.array([EXACT[function](x, y) for x, y in zip(a, b, strict=True)],
                        dtype=np.uint32)
    wrong = np.nonzero(got != expected)[0]
    assert len(cases) > 10_000 and not len(wrong), [
        (hex(bits(a[n])), hex(bits(b[n])), hex(got[n]), hex(expected[n])) for n in wrong[:8]]


def every_significand(high_bits):
    """The 2^23 floats whose bits are high_bits | significand, in chunks of 2^21."""
    for start in range(0, 2**23, 2**21):
        significands = np.arange(start, start + 2**21, dtype=np.uint32)
        yield (np.uint32(high_bits) | significands).view(np.float32)


def test_square_root_is_correctly_rounded_for_every_float(ctx):
    # the root's estimate and its correction see only the significand and whether the
    # exponent is odd: 1 and 2 times every significand cover all positive normal floats
    for high_bits in (0x3F800000, 0x40000000):
        for x in every_significand(high_bits):
            cases = np.zeros((len(x), 3, 3), np.float32)
            cases[:, 0, 0] = x
            got = run_function(ctx, "f_sqrt", cases)[:, 0]
            assert (bits(got) == bits(np.sqrt(x.astype(np.float64)).astype(np.float32))).all()


def test_division_is_correctly_rounded_for_every_divisor_significand(ctx):
    # the quotient's estimate rests on the divisor's reciprocal: every divisor
    # significand, by the smallest and the largest dividend significand
    for dividend in (np.float32(1.0), np.float32(2.0) - np.float32(2.0**-23)):
        for b in every_significand(0x3F800000):
            cases = np.zeros((len(b), 3, 3), np.float32)
            cases[:, 0, 0], cases[:, 1, 0] = dividend, b
            got = run_function(ctx, "f_div", cases)[:, 0]
            expected = (np.float64(dividend) / b.astype(np.float64)).astype(np.float32)
            assert (bits(got) == bits(expected)).all()


SPECIAL_VALUES = [  # function, operands, expected bits
    ("f_div", (0.0, 0.0), QUIET_NAN), ("f_div", (1.0, -0.0), 0xFF800000),
    ("f_div", (-0.0, 5.0), 0x80000000), ("f_div", (np.inf, np.inf), QUIET_NAN),
    ("f_div", (1.0, np.inf), 0), ("f_div", (2.0**-100, 2.0**30), 0),
    ("f_div", (2.0**100, 2.0**-30), 0x7F800000), ("f_div", (1e-45, 1.0), 0),
    ("f_sqrt", (-0.0,), 0x80000000), ("f_sqrt", (-1.0,), QUIET_NAN),
    ("f_sqrt", (np.inf,), 0x7F800000), ("f_sqrt", (1e-45,), 0), ("f_sqrt", (4.0,), 0x40000000),
    ("f_exp", (-np.inf,), 0), ("f_exp", (np.inf,), 0x7F800000), ("f_exp", (0.0,), 0x3F800000),
    ("f_exp", (-87.5,), 0), ("f_exp", (88.75,), 0x7F800000), ("f_exp", (np.nan,), QUIET_NAN),
    ("f_log", (1.0,), 0), ("f_log", (0.0,), 0xFF800000), ("f_log", (1e-45,), 0xFF800000),
    ("f_log", (-1.0,), QUIET_NAN), ("f_log", (np.inf,), 0x7F800000),
    ("f_pow", (1.0, 1000.0), 0x3F800000), ("f_pow", (7.0, 0.0), 0x3F800000),
    ("f_pow", (-2.0, 2.0), QUIET_NAN),
    ("f_sin", (0.0,), 0), ("f_sin", (-0.0,), 0), ("f_sin", (np.inf,), QUIET_NAN),
    ("f_cos", (0.0,), 0x3F800000), ("f_cos", (-np.inf,), QUIET_NAN),
    # beyond the reduction's range inf - inf makes a NaN inside: the quiet one, not the
    # hardware's (x86 0xffc00000, NVIDIA 0x7fffffff)
    ("f_cos", (2.0**100,), QUIET_NAN), ("f_sin", (2.0**100,), 0xFF800000),
    ("f_mul", (2.0**-70, 2.0**-70), 0), ("f_mul", (-(2.0**-70), 2.0**-70), 0x80000000),
    ("f_mul", (0.0, np.inf), QUIET_NAN), ("f_add", (np.inf, -np.inf), QUIET_NAN),
    ("f_add", (1e-45, 0.0), 0), ("f_ftz", (-1e-45,), 0x80000000), ("f_ftz", (np.nan,), None),
]


@pytest.mark.parametrize(("function", "arguments", "expected"), SPECIAL_VALUES)
def test_special_values(function, arguments, expected):
    arguments = [np.float32(x) for x in arguments]
    result = int(bits(getattr(portable, function)(*arguments)))
    if expected is None:  # f_ftz leaves a NaN as it is
        expected = int(bits(arguments[0]))
    assert hex(result) == hex(expected)


# --- accuracy ----------------------------------------------------------------------------

@pytest.mark.parametrize("accuracy", ACCURACY, ids=lambda a: f"{a.function} {a.domain}")
def test_accuracy_within_the_stated_bound(accuracy):
    assert measure(accuracy, 1_000_000) <= accuracy.bound_ulp


def test_the_error_measure_counts_ulp_of_the_true_value():
    exact_values = np.array([1.0, 1.0, 2.0**-126, 3.0])
    results = np.array([1.0 + 2.0**-23, 1.0 - 2.0**-24, 2.0**-126, 3.0], dtype=np.float32)
    assert ulp_error(results, exact_values).tolist() == [1.0, 0.5, 0.0, 0.0]


# --- native mode ---------------------------------------------------------------------

def test_native_mode_gives_the_builtins_results(ctx):
    rng = np.random.default_rng(3)
    cases = rng.uniform(0.5, 4.0, (4096, 3, 3)).astype(np.float32)
    a, b = cases[:, 0, 0], cases[:, 1, 0]
    for function, expected in [("f_add", a + b), ("f_sub", a - b), ("f_mul", a * b)]:
        assert (bits(run_function(ctx, function, cases, "native")[:, 0]) == bits(expected)).all()
    # within the spec's bounds (GLSL 4.30, 4.7.1): 2.5 ULP for a / b, 3 + 2|x| for exp,
    # sqrt as 1 / inversesqrt
    reference = {"f_div": (a.astype(np.float64) / b, 2.5),
                 "f_exp": (np.exp(a.astype(np.float64)), 3.0 + 2.0 * 4.0),
                 "f_sqrt": (np.sqrt(a.astype(np.float64)), 5.0)}
    for function, (values, bound) in reference.items():
        native = run_function(ctx, function, cases, "native")[:, 0]
        assert ulp_error(native, values).max() <= bound, function
    # native f_ftz keeps a subnormal, f_normalize is the built-in's unit vector
    cases[0, 0, 0] = np.float32(1e-45)
    assert bits(run_function(ctx, "f_ftz", cases[:1], "native")[0, 0]) == 1
    unit = run_function(ctx, "f_normalize vec3", cases, "native")
    assert np.allclose(np.linalg.norm(unit, axis=1), 1.0, atol=1e-6)


# --- the shader as drivers see it ------------------------------------------------------

def probe_builds(repeats=(0, 8)):
    return [Build(ARITHMETIC_PROBE, tuple(sorted(probe_defines(f, mode, r).items())), "test")
            for f in FUNCTIONS for mode in ("native", "portable") for r in repeats]


@pytest.mark.requires("glslang")
def test_every_probe_passes_the_reference_front_end_in_both_modes():
    findings = check_sources(probe_builds())
    assert findings == [], "\n".join(map(str, findings[:5]))


PREPROCESS_ONLY = ProgramSpec("probes/arithmetic.glsl", ("compute",), ("FUNCTION", "REPEAT"))


def preprocessed(spec, defines, tmp_path):
    source = tmp_path / "probe.comp"
    source.write_text(spec.sources(defines)["compute"].text)
    result = subprocess.run(["glslangValidator", "-E", str(source)], capture_output=True,
                            text=True, check=False)
    assert result.returncode == 0, result.stdout[-2000:]
    return [line for line in result.stdout.splitlines()
            if line.strip() and not line.startswith("#line")]


@pytest.mark.requires("glslang")
def test_without_arithmetic_defined_the_mode_is_native(tmp_path):
    unset = preprocessed(PREPROCESS_ONLY, {"FUNCTION": 4, "REPEAT": 0}, tmp_path)
    native = preprocessed(ARITHMETIC_PROBE, probe_defines("f_div", "native"), tmp_path)
    portable_mode = preprocessed(ARITHMETIC_PROBE, probe_defines("f_div", "portable"), tmp_path)
    assert unset == native != portable_mode
    assert any("return a / b;" in line for line in unset)


def test_an_unknown_mode_is_refused(ctx):
    with pytest.raises(ShaderError, match="ARITHMETIC must be"):
        ARITHMETIC_PROBE.build(ctx, probe_defines("f_add", "native") | {"ARITHMETIC": 2})


FORBIDDEN = ("exp", "exp2", "log", "log2", "pow", "sqrt", "inversesqrt", "sin", "cos", "tan",
             "asin", "acos", "atan", "sinh", "cosh", "tanh", "asinh", "acosh", "atanh",
             "length", "normalize", "distance", "dot", "cross", "mix", "fma", "mod", "modf",
             "fract", "smoothstep", "faceforward", "reflect", "refract", "radians",
             "degrees", "ldexp", "frexp", "determinant", "inverse", "outerProduct",
             "matrixCompMult", "packHalf2x16", "unpackHalf2x16")


def portable_branch(text):
    """The text between `#if ARITHMETIC_MODE == ARITHMETIC_PORTABLE` and its `#else`."""
    start = text.index("#if ARITHMETIC_MODE == ARITHMETIC_PORTABLE")
    end = text.index("#else  // ARITHMETIC_NATIVE", start)
    return text[start:end]


def open_precision_uses(text):
    """What the portable branch uses whose precision the GLSL spec leaves to the driver,
    and float locals declared without `precise` (the compiler may then fuse a*b+c)."""
    code = re.sub(r"//[^\n]*|/\*.*?\*/", "", portable_branch(text), flags=re.S)
    found = [f"{name}()" for name in FORBIDDEN if re.search(rf"\b{name}\s*\(", code)]
    found += ["the / operator"] if "/" in code else []
    found += [f"not precise: {m[0].strip()}"
              for m in re.finditer(r"^\s*(?:float|vec[234])\s+\w+\s*=.*[-+*].*$", code, re.M)]
    return found


def test_the_portable_shader_uses_only_what_the_spec_pins_down():
    text = arithmetic_text()
    assert "f_div" in portable_branch(text) and "f_exp" in portable_branch(text)
    assert open_precision_uses(text) == []


@pytest.mark.parametrize(("line", "edited", "finding"), [
    ("return f_sqrt(f_dot(x, x));", "return sqrt(dot(x, x));", "sqrt()"),
    ("return f_sqrt(f_dot(x, x));", "return sqrt(dot(x, x));", "dot()"),
    ("precise float sum = a + b;", "precise float sum = a / b;", "the / operator"),
    ("precise float sum = a + b;", "float sum = a + b;", "not precise"),
])
def test_the_scan_finds_a_reintroduced_builtin(line, edited, finding):
    text = arithmetic_text()
    edited_text = text.replace(line, edited, 1)
    assert edited_text != text
    assert any(finding in use for use in open_precision_uses(edited_text))


# --- the twin's own rules --------------------------------------------------------------

def test_the_twin_refuses_operands_it_would_round():
    with pytest.raises(TypeError, match="float32"):
        portable.f_add(np.zeros(3), np.float32(1.0))
    with pytest.raises(ValueError, match="not a float32 value"):
        portable.f_mul(np.float32(3.0), 0.1)  # NEP 50 would round 0.1 to float32 silently
    assert portable.f_mul(np.float32(3.0), 0.5) == np.float32(1.5)


def test_the_twin_keeps_float32_and_broadcasts():
    vectors = np.ones((5, 3), np.float32)
    scalars = np.full(5, 2.0, np.float32)
    assert portable.f_mul(scalars[:, np.newaxis], vectors).shape == (5, 3)
    assert portable.f_normalize(vectors).shape == (5, 3)
    assert portable.f_dot(vectors, vectors).tolist() == [3.0] * 5
    for function in (portable.f_exp, portable.f_log, portable.f_sin, portable.f_cos,
                     portable.f_sqrt, portable.f_ftz):
        assert function(scalars).dtype == np.float32
    assert bits(portable.f_add(SPECIALS, SPECIALS)).dtype == np.uint32


# --- the cost table ------------------------------------------------------------------------

def test_the_cost_table_times_each_function_in_both_modes(ctx):
    costs = call_costs(ctx, ("f_add", "f_div"), cases=256, repeat=2, twin_elements=1000)
    assert [cost.function for cost in costs] == ["f_add", "f_div"]
    assert all(math.isfinite(value) and value >= 0.0 for cost in costs
               for value in (cost.native_ns, cost.portable_ns, cost.twin_ns))
    assert costs[1].twin_ns > 0.0
    assert table(costs).count("\n| `f_") == 2
