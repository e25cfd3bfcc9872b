"""The covering-array generator on small domains: every pair some valid row holds is in a
row, every row is valid, the included rows come first, and the same arguments give the
same rows (`cavesim.gpu.covering_array`)."""

import itertools
import os
import random
import subprocess
import sys
from pathlib import Path

import pytest

from cavesim.gpu import covering_array
from cavesim.gpu.covering_array import cover_pairs, pairs, uncovered_pairs

ROOT = Path(__file__).parents[2]
BINARY = {name: (0, 1) for name in "ABCDEF"}
MIXED = {"INTEGRATOR": tuple(range(8)), "COLLISION": (0, 1, 2), "DRAG": (0, 1),
         "DISPERSION": (0, 1), "TRACERS": (0, 1), "METHOD": (0, 1, 2, 3, 4)}


def rules(row) -> bool:
    """the features' kind of rules: dispersion needs drag and a ground, tracers need drag
    and no dispersion, the adaptive method (4) only with tracers, else the integrator's."""
    return ((row["DRAG"] or not (row["DISPERSION"] or row["TRACERS"]))
            and (row["COLLISION"] or not row["DISPERSION"])
            and not (row["TRACERS"] and row["DISPERSION"])
            and row["METHOD"] == (4 if row["TRACERS"] and row["METHOD"] == 4
                                  else row["INTEGRATOR"] % 4))


def every_valid_pair(domains, valid) -> set:
    """The pairs of every valid row of the product: what the search must find."""
    names = tuple(domains)
    return {pair for values in itertools.product(*domains.values())
            if valid(row := dict(zip(names, values, strict=True)))
            for pair in pairs(row, names)}


def test_without_constraints_every_pair_is_required_and_held():
    cover = cover_pairs(BINARY, lambda row: True)
    assert len(cover.required) == 15 * 4 and cover.excluded == ()
    assert uncovered_pairs(cover.rows, cover.required, tuple(BINARY)) == []
    assert len(cover.rows) <= 8  # 6 binary factors: 6 rows at best, 64 in the product


def test_the_required_pairs_are_exactly_those_some_valid_row_holds():
    cover = cover_pairs(MIXED, rules)
    assert set(cover.required) == every_valid_pair(MIXED, rules)
    assert (("DISPERSION", 1), ("TRACERS", 1)) in cover.excluded
    assert (("INTEGRATOR", 5), ("METHOD", 4)) in cover.required  # with tracers only
    assert all(rules(row) for row in cover.rows)
    assert uncovered_pairs(cover.rows, cover.required, tuple(MIXED)) == []
    assert len(cover.rows) < 40  # 8 integrators x 3 collisions: 24 rows at best


def test_a_pair_held_only_by_rare_rows_is_found():
    # (A=1, B=1) only where C..F are all 1: 1 row in 64
    def valid(row):
        return not (row["A"] and row["B"]) or all(row[n] for n in "CDEF")

    cover = cover_pairs(BINARY, valid)
    assert set(cover.required) == every_valid_pair(BINARY, valid)
    assert any(row["A"] and row["B"] for row in cover.rows)


def test_the_search_finds_every_pair_from_one_valid_row_without_a_sample(monkeypatch):
    monkeypatch.setattr(covering_array, "SAMPLE", 0)
    start = {"INTEGRATOR": 0, "COLLISION": 0, "DRAG": 0, "DISPERSION": 0, "TRACERS": 0,
             "METHOD": 0}
    cover = cover_pairs(MIXED, rules, [start])
    assert set(cover.required) == every_valid_pair(MIXED, rules)
    assert uncovered_pairs(cover.rows, cover.required, tuple(MIXED)) == []


def test_included_rows_come_first_as_given():
    include = [{"A": 1, "B": 1, "C": 1, "D": 1, "E": 1, "F": 1},
               {"A": 0, "B": 1, "C": 0, "D": 1, "E": 0, "F": 7}]  # a value beyond the domain
    cover = cover_pairs(BINARY, lambda row: True, include)
    assert list(cover.rows[:2]) == include
    assert uncovered_pairs(cover.rows, cover.required, tuple(BINARY)) == []


def test_a_dropped_row_leaves_pairs_uncovered():
    cover = cover_pairs(MIXED, rules)
    # the last row added held a pair no row before it did
    assert uncovered_pairs(cover.rows[:-1], cover.required, tuple(MIXED)) != []


def test_an_included_row_the_predicate_refuses_is_an_error():
    def no_tracers(row):
        return rules(row) and not row["TRACERS"]

    included = {"INTEGRATOR": 7, "COLLISION": 1, "DRAG": 1, "DISPERSION": 0, "TRACERS": 1,
                "METHOD": 4}
    with pytest.raises(ValueError, match=r"included row is not valid by the predicate "
                                         r"no_tracers: \{'INTEGRATOR': 7"):
        cover_pairs(MIXED, no_tracers, [included])
    with pytest.raises(ValueError, match=r"lacks \['METHOD'\]"):
        cover_pairs(MIXED, rules, [{k: v for k, v in included.items() if k != "METHOD"}])


def test_the_same_arguments_give_the_same_rows_whatever_the_global_random_state():
    random.seed(1)
    state = random.getstate()
    first = cover_pairs(MIXED, rules)
    assert random.getstate() == state  # the global generator is neither used nor moved
    random.seed(2)
    assert cover_pairs(MIXED, rules) == first


def test_the_same_rows_under_another_hash_seed():
    # the iteration order of a set of strings changes with PYTHONHASHSEED: the rows must not
    script = ("from test_covering_array import MIXED, rules\n"
              "from cavesim.gpu.covering_array import cover_pairs\n"
              "print(cover_pairs(MIXED, rules))\n")
    outputs = {subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, check=True, cwd=ROOT,
        env={**os.environ, "PYTHONHASHSEED": seed,
             "PYTHONPATH": os.pathsep.join([str(ROOT), str(Path(__file__).parent)])}).stdout
        for seed in ("0", "1", "12345")}
    assert len(outputs) == 1
