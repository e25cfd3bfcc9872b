"""The portability gate: every program cavesim can build, checked as any GL 4.3 driver sees it.

Mesa's llvmpipe accepts GLSL that stricter drivers reject, so every assembled stage of every
program of every scene given (the shipped ones in config/scenes/, the scene files under
tests/), of the particle passes in a few rows that cover every pair of feature values and
every `#if` branch (`cavesim.gpu.gate_cover`), and of the other programs in every combination
of their defines, is
  1. linted for what a driver is known to reject though the GLSL spec allows it,
  2. validated by the Khronos reference front-end, `glslangValidator` (Debian package
     `glslang-tools`), and
  3. compiled and linked on a GL context, its uniforms held to the smallest GL 4.3 limits
     (not the particle passes in portable arithmetic: `context_builds`).
A finding names the program, its defines, the stage and the message with `file.glsl:LINE`.
`python -m cavesim.gpu.shader_gate --summary` says what the gate builds and covers without
compiling; without `--summary` it runs the gate and prints one line a finding.
"""

from __future__ import annotations

import argparse
import math
import re
import shutil
import subprocess
import sys
import tempfile
import tomllib
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import moderngl

from cavesim.core.errors import ShaderError
from cavesim.core.scene import Arithmetic, Scene, load_scene
from cavesim.gpu.engine.programs import (
    ARITHMETIC_IDS,
    BLOCK_UPDATE,
    PARTICLE_UPDATE,
    feature_combinations,
    physics_defines,
    scene_programs,
)
from cavesim.gpu.gate_cover import PASSES, ParticleCover, particle_cover
from cavesim.gpu.gl.arithmetic_probe import ARITHMETIC_PROBE, probe_defines
from cavesim.gpu.gl.denormal_probe import DENORMAL_PROBE_DISPATCH, DENORMAL_PROBE_DRAW
from cavesim.gpu.gl.filtering import FILTER_PROBE
from cavesim.gpu.render.programs import render_combinations, render_programs
from cavesim.gpu.shader_conditionals import Branch
from cavesim.gpu.shader_source import ProgramSpec, ShaderSource

VALIDATOR = "glslangValidator"
STAGE_EXTENSIONS = {"vertex": "vert", "geometry": "geom", "fragment": "frag",
                    "compute": "comp"}
# The smallest default-block uniform storage a GL 4.3 driver may offer per stage, in
# components (OpenGL 4.3 core, table 23.57 ff.: MAX_*_UNIFORM_COMPONENTS).
GL43_UNIFORM_COMPONENTS = {"vertex": 1024, "geometry": 1024, "fragment": 1024, "compute": 512}
_LINE_DIRECTIVE = re.compile(r"\s*#\s*line\b")
_BATCH = 400  # sources per glslangValidator run
PORTABLE = ARITHMETIC_IDS[Arithmetic.PORTABLE]
ROOT = Path(__file__).parents[2]
SHIPPED_SCENES = ROOT / "config" / "scenes"
TEST_SCENES = ROOT / "tests"  # the scene files under it: a scene has a [simulation] table


@dataclass(frozen=True)
class Build:
    """One program with one set of defines, and where the gate found it."""

    spec: ProgramSpec
    defines: tuple[tuple[str, int], ...]
    origin: str  # "scene <name>", "cover: value pairs", "cover: branches", "feature combination"

    def __str__(self) -> str:
        values = ", ".join(f"{k}={v}" for k, v in self.defines)
        return f"{self.spec.name} [{values}] ({self.origin})"


@dataclass(frozen=True)
class Finding:
    build: Build
    stage: str  # or "link"
    message: str

    def __str__(self) -> str:
        return f"{self.build} {self.stage}: {self.message}"


def scene_files(shipped: Path = SHIPPED_SCENES, tests: Path = TEST_SCENES) -> list[Path]:
    """The shipped scenes, then the scene files under `tests` (where there is one)."""
    found = sorted(shipped.glob("*.toml"))
    for path in sorted(tests.rglob("*.toml")) if tests.is_dir() else ():
        if "simulation" in tomllib.loads(path.read_text(encoding="utf-8")):
            found.append(path)
    return found


def load_scenes(paths: Iterable[Path]) -> dict[str, Scene]:
    """Scenes by name: a file's stem, or its path where two files share one."""
    scenes: dict[str, Scene] = {}
    for path in paths:
        scenes[path.stem if path.stem not in scenes else str(path)] = load_scene(path)
    return scenes


def scene_cover(scenes: Mapping[str, Scene]) -> ParticleCover:
    """The particle passes' rows for these scenes (`gate_cover.particle_cover`)."""
    return particle_cover({name: physics_defines(scene) for name, scene in scenes.items()})


def all_builds(scenes: Mapping[str, Scene] | Path,
               cover: ParticleCover | None = None) -> list[Build]:
    """Every program of every scene (by name, or the scene files of a folder), the particle
    passes in every row of `cover` (by default the scenes' own), every other program in
    every combination, the probes."""
    if isinstance(scenes, Path):
        scenes = load_scenes(sorted(scenes.glob("*.toml")))
    cover = scene_cover(scenes) if cover is None else cover
    builds: dict[tuple, Build] = {}

    def add(pairs: Iterable[tuple[ProgramSpec, dict]], origin: str) -> None:
        for spec, defines in pairs:
            build = Build(spec, tuple(sorted(defines.items())), origin)
            builds.setdefault((spec, build.defines), build)

    for name, scene in scenes.items():
        add([*scene_programs(scene), *render_programs(scene)], f"scene {name}")
    for row, origin in zip(cover.rows, cover.origins, strict=True):
        add([(spec, {**row, **fixed}) for spec, fixed in PASSES.items()], f"cover: {origin}")
    add([*feature_combinations(), *render_combinations()], "feature combination")
    add([(FILTER_PROBE, {}), (DENORMAL_PROBE_DRAW, {}), (DENORMAL_PROBE_DISPATCH, {})],
        "probe")
    add([(ARITHMETIC_PROBE, probe_defines("f_normalize vec3", mode)) for mode in ARITHMETIC_IDS],
        "probe")
    return list(builds.values())


def lint(source: ShaderSource) -> list[str]:
    """What drivers are known to reject in an assembled stage, though the spec allows it."""
    lines = source.text.rstrip("\n").splitlines()
    if lines and _LINE_DIRECTIVE.match(lines[-1]):
        return [f"the source ends with {lines[-1]!r}: NVIDIA rejects a #line directive as "
                f"the last line (error C0115: #line source-string number invalid)"]
    return []


def check_sources(builds: Iterable[Build], validator: str = VALIDATOR) -> list[Finding]:
    """Lint every stage of every build and run the reference front-end over it."""
    if shutil.which(validator) is None:
        raise ShaderError(f"{validator} not found: install the Debian package glslang-tools "
                          f"(`apt-get install glslang-tools`, or run deploy/setup.sh --test)")
    findings: list[Finding] = []
    stages: list[tuple[Build, str, ShaderSource]] = []
    builds = list(builds)
    assembled = _assembled(builds)
    for build in builds:
        for stage, source in assembled[build].items():
            findings += [Finding(build, stage, problem) for problem in lint(source)]
            stages.append((build, stage, source))
    with tempfile.TemporaryDirectory(prefix="cavesim-gate-") as folder:
        for start in range(0, len(stages), _BATCH):
            findings += _validate(stages[start:start + _BATCH], Path(folder), validator)
    return findings


def _assembled(builds: list[Build]) -> dict[Build, dict[str, ShaderSource]]:
    """The sources of every build; each program's files are pasted once, not once a variant
    (thousands of particle-pass variants: most of the gate's time in Python)."""
    by_spec: dict[ProgramSpec, list[Build]] = {}
    for build in builds:
        by_spec.setdefault(build.spec, []).append(build)
    assembled = {}
    for spec, group in by_spec.items():
        each = spec.variant_sources([dict(build.defines) for build in group])
        assembled.update(zip(group, each, strict=True))
    return assembled


def _validate(stages: list[tuple[Build, str, ShaderSource]], folder: Path,
              validator: str) -> list[Finding]:
    """One glslangValidator run over many files; it prints each file's name, then its log."""
    paths = {}
    for number, (build, stage, source) in enumerate(stages):
        path = folder / f"{number:05d}.{STAGE_EXTENSIONS[stage]}"
        path.write_text(source.text)
        paths[str(path)] = (build, stage, source)
    result = subprocess.run([validator, *paths], capture_output=True, text=True, check=False)
    logs: dict[str, list[str]] = {}
    current = None
    for line in result.stdout.splitlines():
        if line in paths:
            current = logs.setdefault(line, [])
        elif current is not None and line.startswith("ERROR:"):
            current.append(line)
    findings = [Finding(paths[path][0], paths[path][1], paths[path][2].explain("\n".join(log)))
                for path, log in logs.items() if log]
    if result.returncode != 0 and not findings:
        raise ShaderError(f"{validator} failed (exit {result.returncode}) without naming a "
                          f"file: {(result.stderr or result.stdout).strip()[:300]}")
    return findings


def context_builds(builds: Iterable[Build]) -> list[Build]:
    """The builds the context step compiles: all but the particle passes in portable
    arithmetic. Their inlined arithmetic takes llvmpipe about 2 s a program; they declare no
    uniform of their own, the reference front-end validates every one, and
    tests/gpu/test_portable_physics.py compiles and runs every integrator on both paths."""
    return [build for build in builds if build.spec not in (PARTICLE_UPDATE, BLOCK_UPDATE)
            or dict(build.defines)["ARITHMETIC"] != PORTABLE]


def check_on_context(ctx: moderngl.Context, builds: Iterable[Build]) -> list[Finding]:
    """Compile and link every build on `ctx`; hold its uniforms to the GL 4.3 minimums."""
    findings = []
    for build in builds:
        try:
            program = build.spec.build(ctx, dict(build.defines))
        except ShaderError as e:
            findings.append(Finding(build, "link", str(e)))
            continue
        used = uniform_components(program)
        allowed = min(GL43_UNIFORM_COMPONENTS[stage] for stage in build.spec.stages)
        if used > allowed:
            findings.append(Finding(build, "link", f"{used} uniform components (each array "
                                    f"element a vec4), more than the {allowed} a GL 4.3 "
                                    f"driver must offer"))
        program.release()
    return findings


def uniform_components(program: moderngl.Program | moderngl.ComputeShader) -> int:
    """Default-block uniform storage, counted as strict drivers do: a vec4 per element."""
    total = 0
    for name in program:
        member = program[name]
        if isinstance(member, moderngl.Uniform):
            total += max(1, member.array_length) * 4 * math.ceil(member.dimension / 4)
    return total


def summary(scenes: Mapping[str, Scene], cover: ParticleCover,
            builds: Sequence[Build]) -> list[str]:
    """What the gate builds and what the particle passes' rows cover, a line each."""
    native = sum(row["ARITHMETIC"] != PORTABLE for row in cover.rows)
    pairs = cover.pairs
    kinds = ["scenes" if origin.startswith("scene ") else origin for origin in cover.origins]
    lines = [f"variants per path: {len(cover.rows)}",
             f"  native {native}, portable {len(cover.rows) - native}; rows for "
             + ", ".join(f"{kind} {kinds.count(kind)}" for kind in dict.fromkeys(kinds)),
             f"value pairs covered: {len(pairs.required) - len(cover.uncovered)} of "
             f"{len(pairs.required)} required ({len(pairs.excluded)} pairs of values no valid "
             f"combination holds)",
             "branches covered (taken by a variant, of those a valid combination takes):"]
    lines += [f"  {stage}" for stage in cover.stages]
    unreachable: dict[Branch, list[str]] = {}
    for stage in cover.stages:
        for branch in stage.unreachable:
            unreachable.setdefault(branch, []).append(f"{stage.stage} {stage.arithmetic}")
    lines.append("unreachable branches (no valid combination takes them), and where:")
    lines += [f"  {branch}: {'everywhere' if len(where) == len(cover.stages) else ', '.join(where)}"
              for branch, where in unreachable.items()]
    missed = [f"{stage.program} {stage.stage} {stage.arithmetic}: {branch}"
              for stage in cover.stages for branch in stage.missed]
    lines.append(f"branches a valid combination takes and no variant does: {len(missed)}")
    lines += [f"  {line}" for line in missed]
    lines.append(f"#errors a valid combination reaches: {len(cover.errors)}")
    lines += [f"  {error}" for error in cover.errors]
    lines.append(f"scenes included: {len(scenes)} ({', '.join(scenes)})")
    stages = sum(len(build.spec.stages) for build in builds)
    passes = sum(build.spec in PASSES for build in builds)
    lines.append(f"builds in all: {len(builds)} ({passes} particle passes, "
                 f"{len(builds) - passes} other programs and probes), {stages} stages; "
                 f"{len(context_builds(builds))} compiled on the context")
    return lines


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m cavesim.gpu.shader_gate",
        description="Check every program cavesim builds with the reference front-end, a lint "
                    "and this machine's GL context; print one line a finding.")
    parser.add_argument("--summary", action="store_true",
                        help="say what the gate builds and covers, compile nothing")
    parser.add_argument("--scene", type=Path, action="append", default=[],
                        help="a scene file to check besides the shipped ones and those "
                             "under tests/ (repeatable)")
    args = parser.parse_args(argv)
    scenes = load_scenes([*scene_files(), *args.scene])
    cover = scene_cover(scenes)
    builds = all_builds(scenes, cover)
    print("\n".join(summary(scenes, cover, builds)), flush=True)
    if args.summary:
        return 0
    findings = [*(f"uncovered value pair {pair}" for pair in cover.uncovered),
                *(f"missed branch {line}" for line in
                  (f"{s.program} {s.stage} {s.arithmetic}: {b}" for s in cover.stages
                   for b in s.missed)),
                *(f"#error reached by a valid combination: {e}" for e in cover.errors)]
    findings += map(str, check_sources(builds))
    from cavesim.gpu.gl.context import create_context  # a context only for the full gate

    ctx = create_context()
    try:
        findings += map(str, check_on_context(ctx, context_builds(builds)))
    finally:
        ctx.release()
    print("\n".join(findings) if findings else "no findings")
    return 1 if findings else 0


if __name__ == "__main__":
    sys.exit(main())
