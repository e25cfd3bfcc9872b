"""The variants of the particle passes the shader gate compiles, and what they cover.

The particle pass (`particles/update.glsl` on the GS/TF path, `particles/update_blocks.glsl`
on the compute path) has a define per setting of a feature (`programs.PASS_DEFINES`):
their product is millions of programs.
The gate (`cavesim.gpu.shader_gate`) compiles each path in the same few rows instead:
  1. every scene it is given, as the scene builds it;
  2. a covering array (`cavesim.gpu.covering_array`): every pair of values that a valid
     combination of the defines (`programs.valid_physics`) holds is in some row;
  3. rows added until every `#if`/`#elif`/`#else` branch of each stage that a valid
     combination takes is taken by some row, in native and in portable arithmetic
     (`cavesim.gpu.shader_conditionals` decides the branches on the text).
A branch no valid combination found takes (an `#error`, a stage's other side) is told
apart as unreachable; an `#error` that a valid row reaches is a finding: the validity
allows what the shaders refuse.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Mapping
from dataclasses import dataclass

from cavesim.core.scene import Arithmetic
from cavesim.gpu.covering_array import Cover, Row, cover_pairs, uncovered_pairs
from cavesim.gpu.engine.programs import (
    ARITHMETIC_IDS,
    BLOCK_DEFINES,
    BLOCK_UPDATE,
    PARTICLE_UPDATE,
    PASS_DEFINES,
    valid_physics,
)
from cavesim.gpu.shader_conditionals import Branch, Conditionals
from cavesim.gpu.shader_source import ProgramSpec

FEATURES: dict[str, tuple[int, ...]] = PASS_DEFINES
# each engine path's particle pass, and the defines it has besides FEATURES
PASSES: dict[ProgramSpec, dict[str, int]] = {PARTICLE_UPDATE: {}, BLOCK_UPDATE: BLOCK_DEFINES}
ARITHMETICS = {mode.value: ARITHMETIC_IDS[mode] for mode in Arithmetic}


@dataclass(frozen=True)
class StageCoverage:
    """The branches of one stage of one pass in one arithmetic: how many its variants take."""

    program: str
    stage: str
    arithmetic: str
    branches: tuple[Branch, ...]  # all of the stage's
    taken: frozenset[Branch]  # by some variant in this arithmetic
    reachable: frozenset[Branch]  # by some valid combination found in this arithmetic

    @property
    def missed(self) -> list[Branch]:
        """Branches a valid combination takes and no variant does (none, once covered)."""
        return [b for b in self.branches if b in self.reachable and b not in self.taken]

    @property
    def unreachable(self) -> list[Branch]:
        return [b for b in self.branches if b not in self.reachable]

    def lines(self, branches: frozenset[Branch]) -> int:
        return sum(b.lines for b in branches)

    def __str__(self) -> str:
        reachable = self.reachable
        return (f"{self.program} {self.stage} {self.arithmetic}: "
                f"{len(self.taken & reachable)} of {len(reachable)} reachable branches "
                f"({len(self.unreachable)} unreachable of {len(self.branches)}), "
                f"{self.lines(self.taken)} of {self.lines(reachable)} lines in branches")


@dataclass(frozen=True)
class ParticleCover:
    """The rows each particle pass is compiled in, and what they cover."""

    rows: tuple[dict[str, int], ...]
    origins: tuple[str, ...]  # of each row: "scene <name>", "value pairs", "branches"
    pairs: Cover
    stages: tuple[StageCoverage, ...]
    errors: tuple[str, ...]  # `#error`s a valid row reaches: "<where>: #error ... [row]"

    @property
    def uncovered(self) -> list:
        """Required pairs of values no row holds (none, once covered)."""
        return uncovered_pairs(self.rows, self.pairs.required, tuple(FEATURES))


def particle_cover(scenes: Mapping[str, Row],
                   valid: Callable[[Row], bool] = valid_physics) -> ParticleCover:
    """The particle passes' rows: `scenes` (name: its particle-pass defines), a cover of
    every pair of values `valid` allows together, and rows for branches left out. Made once
    a process for the same scenes and validity (its search takes seconds)."""
    return _cover(tuple((name, tuple(row.items())) for name, row in scenes.items()), valid)


@functools.cache
def _cover(scenes: tuple[tuple[str, tuple[tuple[str, int], ...]], ...],
           valid: Callable[[Row], bool]) -> ParticleCover:
    scenes = {name: dict(row) for name, row in scenes}
    by_row = {_key(row): name for name, row in reversed(scenes.items())}
    pairs = _pairs_in_each_arithmetic(list(scenes.values()), valid)
    rows = list(pairs.rows)
    origins = [f"scene {by_row[_key(row)]}" if _key(row) in by_row else "value pairs"
               for row in rows]
    programs = _stage_texts(rows[0])
    candidates = _distinct([*rows, *pairs.pool])
    outcomes = {_key(row): [c.taken(_defines(spec, row)) for spec, _, c in programs]
                for row in candidates}

    def arms(row: Row) -> set[tuple[int, int, Branch]]:
        return {(k, row["ARITHMETIC"], branch)
                for k, outcome in enumerate(outcomes[_key(row)]) for branch in outcome.taken}

    reachable = set().union(*map(arms, candidates))
    taken = set().union(*map(arms, rows))
    while need := reachable - taken:  # the candidate that takes most of what is left
        best = max(candidates, key=lambda row: len(arms(row) & need))
        rows.append(best)
        origins.append("branches")
        taken |= arms(best)
    stages = tuple(
        StageCoverage(spec.name, stage, mode, conditionals.branches,
                      frozenset(b for k2, a, b in taken if (k2, a) == (k, value)),
                      frozenset(b for k2, a, b in reachable if (k2, a) == (k, value)))
        for k, (spec, stage, conditionals) in enumerate(programs)
        for mode, value in ARITHMETICS.items())
    errors = tuple(dict.fromkeys(
        f"{error} [{', '.join(f'{n}={v}' for n, v in row.items())}]"
        for row in candidates for outcome in outcomes[_key(row)] for error in outcome.errors))
    return ParticleCover(tuple(rows), tuple(origins), pairs, stages, errors)


def _pairs_in_each_arithmetic(scenes: list[Row], valid: Callable[[Row], bool]) -> Cover:
    """A cover of the value pairs in native arithmetic, then one in portable: the two share
    no line of arithmetic, so each holds every pair with the other's code out of the way."""
    covers = [cover_pairs({**FEATURES, "ARITHMETIC": (value,)}, valid,
                          [row for row in scenes if row["ARITHMETIC"] == value])
              for value in ARITHMETICS.values()]
    required = tuple(dict.fromkeys(p for c in covers for p in c.required))
    excluded = set(p for c in covers for p in c.excluded) - set(required)
    return Cover(tuple(row for c in covers for row in c.rows), required,
                 tuple(p for p in dict.fromkeys(p for c in covers for p in c.excluded)
                       if p in excluded),
                 tuple(row for c in covers for row in c.pool))


def _stage_texts(row: Row) -> list[tuple[ProgramSpec, str, Conditionals]]:
    """Each stage of each pass, parsed once: the defines are decided per row."""
    return [(spec, stage, Conditionals(source.text, source.files))
            for spec in PASSES
            for stage, source in spec.sources(_defines(spec, row)).items()]


def _defines(spec: ProgramSpec, row: Row) -> dict[str, int]:
    return {**row, **PASSES[spec]}


def _key(row: Row) -> tuple:
    return tuple(sorted(row.items()))


def _distinct(rows: list[dict[str, int]]) -> list[dict[str, int]]:
    return list({_key(row): row for row in rows}.values())
