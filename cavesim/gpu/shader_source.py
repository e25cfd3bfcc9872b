"""Assemble GLSL sources from cavesim/gpu/shaders/ and compile them into moderngl programs.

Every program the engine builds passes through here: the assembler picks the stage, injects
the scene's feature `#define`s (strictly: each allowed name decided, no unknown ones), pastes
`#include`d files with `#line` markers, and maps compiler messages back to `file.glsl:LINE`.
"""

import math
import posixpath
import re
from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import moderngl

from cavesim.core.errors import ShaderError
from cavesim.gpu.gl.context import REQUIRED_GL_VERSION

SHADER_ROOT = Path(__file__).parent / "shaders"
STAGE_MACROS = {
    "vertex": "VERTEX_SHADER",
    "geometry": "GEOMETRY_SHADER",
    "fragment": "FRAGMENT_SHADER",
    "compute": "COMPUTE_SHADER",
}
MAX_INCLUDE_DEPTH = 8

Defines = Mapping[str, int | float | bool]
_NAME = re.compile(r"[A-Z][A-Z0-9_]*")
_UNIFORM = re.compile(r"^\s*uniform\s+\w+\s+(\w+)", re.M)
_INT32_RANGE = range(-(2**31), 2**31)
_FLOAT32_MAX = 3.4028234663852886e38
_INCLUDE = re.compile(r'\s*#\s*include\s+"([^"]+)"\s*')
_PRAGMA_ONCE = re.compile(r"\s*#\s*pragma\s+once\s*")
_DEFINE = re.compile(r"\s*#\s*define\s+(\w+)")
_DEFINE_NAME = re.compile(r"^#define (\w+)", re.M)
_VERSION = re.compile(r"\s*#\s*version\b")
_LINE_MARKER = re.compile(r"#line \d+ \d+")
_CONDITIONAL_BRANCH = re.compile(r"\s*#\s*(else|elif|endif)\b")
# A compiler log's leading source and line: Mesa writes `K:LINE(COLUMN)`, NVIDIA `K(LINE)`
_LOCATION = re.compile(r"^(?P<prefix>(?:ERROR|WARNING): )?(?P<source>\d+)"
                       r"(?::(?P<line>\d+)|\((?P<paren_line>\d+)\))", re.M)
_FAILED_STAGE = re.compile(r"^(vertex|geometry|fragment|compute)_shader$", re.M)


@dataclass(frozen=True)
class ShaderSource:
    """One assembled stage: the text to compile and the file behind each `#line` source number."""

    text: str
    files: tuple[str, ...]

    def explain(self, log: str) -> str:
        """Return a compiler log with each leading `K:LINE` (Mesa) or `K(LINE)` (NVIDIA)
        replaced by `file.glsl:LINE`."""

        # Mesa's parser resets the source number to 0 on every grammar rule (YYLLOC_DEFAULT);
        # only token-located messages (syntax, preprocessor, some semantic) keep it. So e.g.
        # an undeclared name on line 2 of an included file reads `0:2` and maps to the main
        # file here, with the right line number.
        def name_file(match: re.Match[str]) -> str:
            source = int(match["source"])
            if source >= len(self.files):
                return match[0]
            line = match["line"] or match["paren_line"]
            return f"{match['prefix'] or ''}{self.files[source]}:{line}"

        return _LOCATION.sub(name_file, log)


@dataclass(frozen=True)
class ProgramSpec:
    """One program: its file under cavesim/gpu/shaders/, its stages, the defines it must be
    given (every one decided), and what transform feedback captures."""

    name: str
    stages: tuple[str, ...]
    allowed: tuple[str, ...] = ()
    varyings: tuple[str, ...] = ()
    root: Path = SHADER_ROOT
    preamble: str = ""  # GLSL pasted after the defines, before the file (ids, #errors)

    def sources(self, defines: Defines) -> dict[str, ShaderSource]:
        """The assembled source of every stage."""
        (sources,) = self.variant_sources([defines])
        return sources

    def variant_sources(self, variants: Sequence[Defines]) -> list[dict[str, ShaderSource]]:
        """`sources` of each set of defines in `variants`, each stage's files pasted once."""
        each = {stage: assemble_each(self.name, stage, variants, self.allowed, self.root,
                                     self.preamble)
                for stage in self.stages}
        return [{stage: each[stage][k] for stage in self.stages} for k in range(len(variants))]

    def build(self, ctx: moderngl.Context,
              defines: Defines) -> moderngl.Program | moderngl.ComputeShader:
        return build_program(ctx, self.name, self.stages, defines, self.allowed,
                             varyings=self.varyings, root=self.root, preamble=self.preamble)


def assemble(
    name: str,
    stage: str,
    defines: Defines,
    allowed: Collection[str],
    root: Path = SHADER_ROOT,
    preamble: str = "",
) -> ShaderSource:
    """Return the source of one stage of the program `name` (relative to `root`)."""
    (source,) = assemble_each(name, stage, [defines], allowed, root, preamble)
    return source


def assemble_each(
    name: str,
    stage: str,
    variants: Sequence[Defines],
    allowed: Collection[str],
    root: Path = SHADER_ROOT,
    preamble: str = "",
) -> list[ShaderSource]:
    """`assemble` for each set of defines in `variants`, `preamble` after the defines. Every
    set names each allowed define (no more), so the pasted files are the same text for all:
    they are pasted once."""
    if stage not in STAGE_MACROS:
        raise ShaderError(f"stage must be one of {sorted(STAGE_MACROS)}, got {stage=!r}")
    headers = [[f"#version {REQUIRED_GL_VERSION} core", *_define_lines(defines, allowed),
                f"#define {STAGE_MACROS[stage]}", *preamble.splitlines()] for defines in variants]
    if not headers:
        return []
    paster = _Paster(root, injected={*variants[0], *STAGE_MACROS.values(),
                                     *_DEFINE_NAME.findall(preamble)})
    body = paster.paste(_resolve(name, "", "shader"), chain=())
    # A position marker that nothing follows marks nothing, and NVIDIA's compiler rejects a
    # `#line` as the last line of a source (C0115: "#line source-string number invalid").
    while body and _LINE_MARKER.fullmatch(body[-1]):
        body.pop()
    text = "".join(f"{line}\n" for line in body)
    files = tuple(paster.files)
    return [ShaderSource("\n".join(header) + "\n" + text, files) for header in headers]


def build_program(
    ctx: moderngl.Context,
    name: str,
    stages: Sequence[str],
    defines: Defines,
    allowed: Collection[str],
    varyings: Sequence[str] = (),
    varyings_capture_mode: str = "interleaved",
    root: Path = SHADER_ROOT,
    preamble: str = "",
) -> moderngl.Program | moderngl.ComputeShader:
    """Compile the program `name` from `stages`; a compute shader if stages is ["compute"]."""
    if list(stages) != ["compute"] and ("vertex" not in stages or "compute" in stages):
        raise ShaderError(
            f"stages must be ['compute'] or include 'vertex' and not 'compute', got {stages=!r}"
        )
    sources = {stage: assemble(name, stage, defines, allowed, root, preamble)
               for stage in stages}
    try:
        if "compute" in sources:
            program = ctx.compute_shader(sources["compute"].text)
        else:
            program = ctx.program(
                **{f"{stage}_shader": source.text for stage, source in sources.items()},
                varyings=varyings,
                varyings_capture_mode=varyings_capture_mode,
            )
    except moderngl.Error as e:
        log = str(e)
        # moderngl titles a compile log with e.g. "fragment_shader"; a link log with "Program".
        failed = _FAILED_STAGE.search(log)
        stage = failed[1] if failed else "link"
        explained = sources[stage].explain(log) if failed else log
        raise ShaderError(f"{name} ({stage} stage): {explained.strip()}") from e
    # the uniforms its source declares (the compiler may drop unused ones from `program`)
    program.extra = {"name": name, "declared": {
        match[1] for source in sources.values() for match in _UNIFORM.finditer(source.text)}}
    return program


def _define_lines(defines: Defines, allowed: Collection[str]) -> list[str]:
    """Return one `#define NAME VALUE` line per define, sorted by name, after strict checks."""
    if isinstance(allowed, str):
        raise ShaderError(f"allowed must be a collection of names, not a string, got {allowed=!r}")
    allowed = set(allowed)
    bad = sorted(n for n in allowed if not _NAME.fullmatch(n) or _is_reserved(n))
    if bad:
        raise ShaderError(
            f"define names must match [A-Z][A-Z0-9_]* and not be reserved "
            f"(GL_*, containing __, {', '.join(STAGE_MACROS.values())}), got {bad}"
        )
    unknown = sorted(set(defines) - allowed)
    if unknown:
        raise ShaderError(f"unknown defines {unknown}; allowed: {sorted(allowed)}")
    missing = sorted(allowed - set(defines))
    if missing:
        raise ShaderError(
            f"defines {missing} missing: every allowed define needs an explicit value "
            f"(allowed: {sorted(allowed)})"
        )
    return [f"#define {n} {_literal(n, defines[n])}" for n in sorted(defines)]


def _is_reserved(name: str) -> bool:
    """Whether GLSL reserves `name` or the assembler injects it itself."""
    return name.startswith("GL_") or "__" in name or name in STAGE_MACROS.values()


def _literal(name: str, value: int | float | bool) -> str:
    """Return `value` as a GLSL literal that reads back exactly."""
    if isinstance(value, bool):
        return "1" if value else "0"
    if isinstance(value, int):
        if value not in _INT32_RANGE:
            raise ShaderError(f"define {name} must fit a 32-bit GLSL int, got {value!r}")
        return str(value)
    if isinstance(value, float):
        if not math.isfinite(value) or abs(value) > _FLOAT32_MAX:
            raise ShaderError(f"define {name} must be a finite float32 value, got {value!r}")
        # repr of a finite float always has '.' or 'e', so GLSL reads it as a float; float()
        # strips subclasses such as numpy.float64, whose repr is "np.float64(...)".
        return repr(float(value))
    raise ShaderError(
        f"define {name} must be bool, int or float, got {type(value).__name__} {value!r}"
    )


class _Paster:
    """Pastes a file and its includes, numbering each file in order of first inclusion."""

    def __init__(self, root: Path, injected: set[str]) -> None:
        self.root = root
        self.injected = injected
        self.files: list[str] = []
        self.once: set[str] = set()  # files with `#pragma once` pasted already

    def paste(self, name: str, chain: tuple[str, ...], included_at: str = "") -> list[str]:
        """Return the lines of `name` with includes expanded, after a `#line 1 K` marker.

        `chain` holds the files including `name`; `included_at` is the `file:line` doing so.
        """
        lines = self._read(name, chain, included_at)
        if name not in self.files:
            self.files.append(name)
        number = self.files.index(name)
        out = [f"#line 1 {number}"]
        for line_number, line in enumerate(lines, start=1):
            where = f"{name}:{line_number}"
            if _PRAGMA_ONCE.fullmatch(line):
                self.once.add(name)
                out.append(f"// {line.strip()}")
            elif include := _INCLUDE.fullmatch(line):
                target = _resolve(include[1], name, where)
                if target in self.once:
                    # no '#' left: moderngl pastes every `#include "..."` it finds in the
                    # text, comments too, and would fail on this one
                    out.append(f"// include {include[1]!r}: pasted already (#pragma once)")
                    continue
                out += self.paste(target, (*chain, name), where)
                out.append(f"#line {line_number + 1} {number}")
            else:
                self._check_directive(line, where)
                out.append(line)
                # The compiler ignores `#line` inside a skipped group, so an include pasted
                # there leaves the count wrong after it; restate the position.
                if _CONDITIONAL_BRANCH.match(line):
                    out.append(f"#line {line_number + 1} {number}")
        return out

    def _read(self, name: str, chain: tuple[str, ...], included_at: str) -> list[str]:
        """Return the lines of `name`, refusing cycles and includes nested too deep."""
        path = " -> ".join([*chain, name])
        if name in chain:
            raise ShaderError(f"{included_at}: #include cycle: {path}")
        if len(chain) > MAX_INCLUDE_DEPTH:
            raise ShaderError(
                f"{included_at}: #include nested deeper than {MAX_INCLUDE_DEPTH}: {path}"
            )
        try:
            return (self.root / name).read_text(encoding="utf-8").splitlines()
        except FileNotFoundError as e:
            what = f"{included_at}: #include" if included_at else "shader"
            raise ShaderError(f"{what} {name!r} not found under {self.root}") from e

    def _check_directive(self, line: str, where: str) -> None:
        """Refuse directives the assembler owns: `#version` and injected `#define`s."""
        if _VERSION.match(line):
            raise ShaderError(f"{where}: remove #version; the assembler writes "
                              f"#version {REQUIRED_GL_VERSION} core")
        define = _DEFINE.match(line)
        if define and define[1] in self.injected:
            raise ShaderError(
                f"{where}: #define {define[1]} conflicts with the injected define; "
                f"the caller decides its value"
            )


def _resolve(target: str, including: str, where: str) -> str:
    """Return `target`, named in file `including`, relative to the shader root."""
    base = "" if target.startswith("/") else posixpath.dirname(including)
    resolved = posixpath.normpath(posixpath.join(base, target.lstrip("/")))
    if resolved == ".." or resolved.startswith("../"):
        raise ShaderError(f"{where}: {target!r} leaves the shader root")
    return resolved
