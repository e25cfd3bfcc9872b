"""Covering arrays: a few rows of feature values in which every pair of values that can
occur together does.

The shader gate (`cavesim.gpu.shader_gate`) compiles the particle pass in the rows of one
instead of in every combination of its defines. Generic: given the values each name can
take, a validity predicate over a whole row and rows that must be in it, `cover_pairs`
finds which pairs of values some valid row holds (the required pairs) and builds rows,
greedily one at a time as AETG does, until every required pair is in one.

The predicate is a black box, so a pair counts as required once a valid row that holds it
is found: in a random sample, or with the pair put into a valid row found and up to two
other values changed. A pair that only rows farther from those hold would be missed;
tests/gpu/test_shader_gate.py holds the search to every valid combination of the particle
pass's defines. Deterministic: the same arguments give the same rows, in the same order, on
every run (the sample comes from a local generator with a fixed seed).
"""

from __future__ import annotations

import itertools
import random
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass

Row = Mapping[str, int]
Value = tuple[str, int]  # a name and one of its values
Pair = tuple[Value, Value]  # in the order of the domains' names
Validity = Callable[[Row], bool]

SAMPLE = 4000  # random rows drawn to start the witness search from
SEEDS = 16  # valid rows a witness search for one pair starts from
CANDIDATES = 8  # rows built for each row chosen (AETG takes the best of several)


@dataclass(frozen=True)
class Cover:
    """The rows (the included ones first) and the pairs they were built to hold."""

    rows: tuple[dict[str, int], ...]
    required: tuple[Pair, ...]  # every pair of domain values some valid row holds
    excluded: tuple[Pair, ...]  # the other pairs of domain values: no valid row found
    pool: tuple[dict[str, int], ...]  # the valid rows the search found (witnesses first)


def pairs(row: Row, names: Sequence[str]) -> Iterable[Pair]:
    """Every pair of values `row` holds, its names in the order of `names`."""
    values = [(name, row[name]) for name in names]
    return itertools.combinations(values, 2)


def cover_pairs(domains: Mapping[str, Sequence[int]], valid: Validity,
                include: Iterable[Row] = (), seed: int = 0) -> Cover:
    """Rows, each valid, that hold every pair of values some valid row holds; `include`
    first, as given. An included row the predicate refuses is an error: one of the two is
    wrong."""
    names = tuple(domains)
    included = [_checked(row, names) for row in include]
    refused = [row for row in included if not valid(row)]
    if refused:
        name = getattr(valid, "__name__", repr(valid))
        raise ValueError(f"an included row is not valid by the predicate {name}: "
                         f"{refused[0]} (either the predicate or the row is wrong)")
    search = _Search(domains, valid, seed)
    for row in included:
        search.keep(row)
    search.sample()
    required = search.required()
    excluded = tuple(p for p in _all_pairs(domains) if p not in search.witness)
    uncovered = dict.fromkeys(required)
    rows = [dict(row) for row in dict.fromkeys(tuple(row.items()) for row in included)]
    for row in rows:
        for pair in pairs(row, names):
            uncovered.pop(pair, None)
    while uncovered:
        candidates = [search.improve(search.witness[pair], pair, uncovered)
                      for pair in itertools.islice(uncovered, CANDIDATES)]
        best = max(candidates, key=lambda row: _gain(row, names, uncovered))
        rows.append(best)
        for pair in pairs(best, names):
            uncovered.pop(pair, None)
    return Cover(tuple(rows), required, excluded, tuple(search.pool))


def uncovered_pairs(rows: Iterable[Row], required: Iterable[Pair],
                    names: Sequence[str]) -> list[Pair]:
    """The required pairs no row holds."""
    held = {pair for row in rows for pair in pairs(row, names)}
    return [pair for pair in required if pair not in held]


def _checked(row: Row, names: Sequence[str]) -> dict[str, int]:
    missing = [name for name in names if name not in row]
    if missing:
        raise ValueError(f"an included row lacks {missing}: {dict(row)}")
    return {name: row[name] for name in names}


def _all_pairs(domains: Mapping[str, Sequence[int]]) -> Iterable[Pair]:
    for (a, a_values), (b, b_values) in itertools.combinations(domains.items(), 2):
        for x, y in itertools.product(a_values, b_values):
            yield (a, x), (b, y)


def _gain(row: Row, names: Sequence[str], uncovered: Mapping[Pair, None]) -> int:
    return sum(pair in uncovered for pair in pairs(row, names))


class _Search:
    """The valid rows found so far, and a witness for each pair they hold."""

    def __init__(self, domains: Mapping[str, Sequence[int]], valid: Validity,
                 seed: int) -> None:
        self.domains = {name: tuple(values) for name, values in domains.items()}
        self.names = tuple(domains)
        self.order = {name: k for k, name in enumerate(self.names)}
        self.valid = valid
        self.random = random.Random(seed)
        self.pool: list[dict[str, int]] = []
        self.witness: dict[Pair, dict[str, int]] = {}

    def keep(self, row: dict[str, int]) -> None:
        """Add a valid row to the pool, the witness of every pair it holds first."""
        self.pool.append(row)
        for pair in pairs(row, self.names):
            self.witness.setdefault(pair, row)

    def sample(self) -> None:
        """Draw rows at random, keep the valid ones."""
        for _ in range(SAMPLE):
            row = {name: self.random.choice(values) for name, values in self.domains.items()}
            if self.valid(row):
                self.keep(row)

    def required(self) -> tuple[Pair, ...]:
        """Every pair of domain values some valid row holds: a witness from the pool, else
        from a search near the pool's rows."""
        for pair in _all_pairs(self.domains):
            if pair not in self.witness and (row := self.find(dict(pair))) is not None:
                self.keep(row)
        return tuple(p for p in _all_pairs(self.domains) if p in self.witness)

    def find(self, fixed: dict[str, int]) -> dict[str, int] | None:
        """A valid row with the values `fixed`: the row of every first value (where each
        define leaves its feature out, most combinations are allowed), or a pool row, with
        them put in and up to two other values changed, starting from the rows that hold most
        of `fixed`."""
        agree = sorted(range(len(self.pool)), key=lambda k: -sum(
            self.pool[k].get(name) == value for name, value in fixed.items()))
        free = [name for name in self.names if name not in fixed]
        first = {name: values[0] for name, values in self.domains.items()}
        for start in (first, *(self.pool[k] for k in agree[:SEEDS])):
            start = {**start, **fixed}
            for changes in range(3):
                for row in self._changed(start, free, changes):
                    if self.valid(row):
                        return row
        return None

    def _changed(self, row: dict[str, int], free: Sequence[str],
                 changes: int) -> Iterable[dict[str, int]]:
        """`row` with `changes` of the names `free` set to another value, every way."""
        for chosen in itertools.combinations(free, changes):
            others = [[v for v in self.domains[name] if v != row[name]] for name in chosen]
            for values in itertools.product(*others):
                yield {**row, **dict(zip(chosen, values, strict=True))}

    def improve(self, row: dict[str, int], pair: Pair,
                uncovered: Mapping[Pair, None]) -> dict[str, int]:
        """`row` (which holds `pair`) with its other values changed, one at a time, while
        the row stays valid and holds more uncovered pairs."""
        fixed = dict(pair)
        best = dict(row)
        improved = True
        while improved:
            improved = False
            for name in self.names:
                if name in fixed:
                    continue
                now = self._held(best, name, best[name], uncovered)
                for value in self.domains[name]:
                    if value == best[name]:
                        continue
                    gain = self._held(best, name, value, uncovered)
                    if gain > now and self.valid(trial := {**best, name: value}):
                        best, now, improved = trial, gain, True
        return best

    def _held(self, row: Row, name: str, value: int, uncovered: Mapping[Pair, None]) -> int:
        """How many uncovered pairs `row` holds with `name` = `value` that involve it."""
        count = 0
        for other in self.names:
            if other != name:
                pair = ((name, value), (other, row[other]))
                count += (pair if self.order[name] < self.order[other]
                          else pair[::-1]) in uncovered
        return count
