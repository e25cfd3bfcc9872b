"""The per-frame counters, one table: every number a wall counts in a frame besides its state.

A row is all there is to a counter. Its `id` is its tag on the wire (stable: never reused),
its `name` the key in `ParticleSystem.counters()`, the twins' `counters()` and report.json's
`counters`. It holds one value per particle class (`per_class`) or `values` values; the GPU
combines into it by adding or by taking the largest (atomics in the particle pass, under the
row's switch: shaders/include/counters.glsl), or copies it from what the passes count anyway
(the drops); it counts `events` (a total over frames means something) or a level; the master
`keeps` of it a total, the first frame it was nonzero, its values binned per frame over the
run (`cavesim.core.bounded.BinnedSums`) and the largest with its frame; a scene counts it
where `counted` says, and the particle pass may where its defines meet `needs` (the same
condition on them, as the C preprocessor reads it: the pass's rule, `#error` and gate
validity); the twins compute it with `twin` from what their step knows (`TwinStep`);
`notice` is the line the master logs once, at the first frame it is nonzero.

Everything else is derived from the table: the GPU buffer's layout and the GLSL defines
(`cavesim/gpu/engine/counter_buffer.py`), the report's tagged counter tail
(`cavesim/core/wire/payloads/from_nodes.py`: an id the master does not know is counted and
skipped, so a new row moves no wire version), the master's agreement on them and its book
(`nodes/lockstep.py`, `nodes/master/counter_book.py`), report.json's section and `cavesim
run`'s rows (`cavesim/tools/reports/run_tables.py`).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from enum import Enum
from typing import Any

import numpy as np

from cavesim.core.features import collision, grid_flow
from cavesim.core.limits import MAX_PARTICLE_CLASSES
from cavesim.core.scene.model import Scene
from cavesim.core.substeps import SubstepCounts

MAX_ENTRIES = 64  # counters one report may carry, known or not
MAX_VALUES = MAX_PARTICLE_CLASSES  # values of one counter
MAX_ID = 0xFFFF  # a two-byte tag; 0 is no counter's


class Combine(Enum):
    """How the GPU makes a frame's value."""

    ADD = "add"  # atomicAdd in the particle pass
    MAX = "max"  # atomicMax in the particle pass
    COPIED = "copied"  # copied on the GPU from what the passes count anyway


class Keep(Enum):
    """What the master keeps of a counter over a run."""

    TOTAL = "total"  # the sum over frames (events only)
    FIRST = "first_frame"  # the first frame each value was nonzero
    BINNED = "per_frame"  # each frame's values, summed into bins of a doubling stride
    LARGEST = "largest"  # each value's largest, and its frame


@dataclass(frozen=True)
class TwinStep:
    """What a twin's step knows of the frame it stepped: the counters' twins read it. The
    arrays are of the particles the step began with, in stream order."""

    twin: Any  # the TwinSystem (cavesim.core.twin.system): its scene, features' data, kernels
    class_id: np.ndarray  # (N,)
    start: np.ndarray  # (N, 3) where each began the step (the record's float32 position)
    pos: np.ndarray  # (N, 3) where each ended it, the bounce included
    sane: np.ndarray  # (N,) whether its step was sane (not run away)
    alive: np.ndarray  # (N,) whether it lives on
    substeps: SubstepCounts  # what the adaptive tracers did (NO_SUBSTEPS: none stepped)
    emitted: int  # new particles the emitters made this frame, kept or not
    live: int  # particles after the frame

    @property
    def classes(self) -> int:
        """Values of a per-class counter (the GPU's CLASS_COUNT)."""
        return max(1, len(self.twin.scene.particle_classes))

    def per_class(self, rows: np.ndarray) -> tuple[int, ...]:
        """How many of the particles `rows` (a mask) are of each class."""
        classes = np.minimum(self.class_id[rows].astype(np.int64), self.classes - 1)
        return tuple(np.bincount(classes, minlength=self.classes).tolist())


@dataclass(frozen=True)
class Counter:
    """One row of the table (see the module docstring)."""

    id: int
    name: str
    label: str  # the run table's row
    unit: str
    per_class: bool
    values: int  # how many values a counter not per class has
    combine: Combine
    events: bool  # a total over frames means something (else: a level)
    keeps: frozenset[Keep]
    counted: Callable[[Scene], bool]
    needs: str  # `counted` on the particle pass's defines ("" for a copied row: no switch)
    twin: Callable[[TwinStep], tuple[int, ...]]
    notice: Callable[[Scene, int, tuple[int, ...]], str] | None = None

    def width(self, scene: Scene) -> int:
        """Its values in `scene`: one per particle class (at least one, as the GPU's
        CLASS_COUNT), or `values`."""
        return max(1, len(scene.particle_classes)) if self.per_class else self.values

    def value_names(self, scene: Scene) -> tuple[str, ...]:
        """What each value counts: the class names, or the values' indices."""
        if self.per_class:
            return class_names(scene)
        return tuple(str(i) for i in range(self.values))

    @property
    def in_pass(self) -> bool:
        """Whether the particle pass combines into it (else the passes' own counts are
        copied)."""
        return self.combine is not Combine.COPIED


def class_names(scene: Scene) -> tuple[str, ...]:
    """A per-class counter's value names: the scene's classes (class 0 where it has none)."""
    return tuple(c.name for c in scene.particle_classes) or ("0",)


# -- when a scene counts, and the twins' sides ------------------------------------------------

def gridded(scene: Scene) -> bool:
    """A gridded flow has a box to leave."""
    return scene.gridded_flow


def emitting(scene: Scene) -> bool:
    """Only emission can outgrow the capacity."""
    return bool(scene.emitters)


def adaptive_tracers(scene: Scene) -> bool:
    """Only tracers stepped by TracerMethod.RK45 take substeps."""
    return scene.tracers_take_substeps


def _exits(step: TwinStep) -> tuple[int, ...]:
    """step_particle's count: a sane step from inside the field's box to outside it."""
    twin = step.twin
    grid = twin.data[grid_flow.GRID_FLOW.name]
    left = (step.sane & ~grid_flow.outside(grid, step.start, twin.kernels)
            & grid_flow.outside(grid, step.pos, twin.kernels))
    return step.per_class(left)


def _deposits(step: TwinStep) -> tuple[int, ...]:
    """step_particle's census: a particle that lives on, on the ground where its step ended
    (the bounce left it there), not above it."""
    twin = step.twin
    ground = collision.COLLISION.ground_at(twin.scene, twin.data[collision.COLLISION.name],
                                           twin.kernels, step.pos[:, :2])
    return step.per_class(step.alive & (step.pos[:, 2] <= ground))


def _drops(step: TwinStep) -> tuple[int, ...]:
    return (int(step.alive.sum()) + step.emitted - step.live,)


_BEYOND = {"clamp": "the nearest boundary node's", "zero": "still air"}


def _exits_notice(scene: Scene, k: int, values: tuple[int, ...]) -> str:
    field = scene.field
    left = ", ".join(f"{n} {name}" for name, n in zip(class_names(scene), values, strict=True)
                     if n)
    return (f"frame {k}: particles left the field's box {list(field.box_min)} .. "
            f"{list(field.box_max)} ({left}); beyond it the flow is "
            f"{_BEYOND[field.out_of_domain.value]} (out_of_domain), not the field's. "
            f"report.json counts every frame's (counters.domain_exits)")


def _drops_notice(scene: Scene, k: int, values: tuple[int, ...]) -> str:
    return (f"capacity full: {values[0]:,} new particles dropped at frame {k} (the scene "
            f"holds {scene.capacity:,}); report.json counts every frame's "
            f"(counters.capacity_drops)")


EVENTS = frozenset({Keep.TOTAL, Keep.FIRST, Keep.BINNED})
# the particle pass's condition for tracers that step in substeps
RK45_TRACERS = "HAS_TRACERS && TRACER_METHOD == TRACER_RK45"

COUNTERS: tuple[Counter, ...] = (
    Counter(1, "domain_exits", "left the field's box", "particles", True, 0, Combine.ADD, True,
            EVENTS, gridded, grid_flow.GRID, _exits, _exits_notice),
    Counter(2, "capacity_drops", "dropped at capacity", "particles", False, 1, Combine.COPIED,
            True, EVENTS, emitting, "", _drops, _drops_notice),
    Counter(3, "tracers_stepped", "tracers stepped", "tracers", False, 1, Combine.ADD, True,
            frozenset({Keep.TOTAL, Keep.BINNED}), adaptive_tracers, RK45_TRACERS,
            lambda step: (step.substeps.tracers,)),
    Counter(4, "substeps_taken", "tracer substeps taken", "substeps", False, 1, Combine.ADD,
            True, frozenset({Keep.TOTAL, Keep.BINNED}), adaptive_tracers, RK45_TRACERS,
            lambda step: (step.substeps.taken,)),
    Counter(5, "substeps_retaken", "tracer substeps retaken", "substeps", False, 1,
            Combine.ADD, True, EVENTS, adaptive_tracers, RK45_TRACERS,
            lambda step: (step.substeps.retaken,)),
    Counter(6, "most_substeps", "most substeps of one tracer", "substeps", False, 1,
            Combine.MAX, False, frozenset({Keep.LARGEST}), adaptive_tracers, RK45_TRACERS,
            lambda step: (step.substeps.most,)),
    # a level: how much has settled, per class (the brownout's sand on the ground)
    Counter(7, "ground_deposits", "on the ground", "particles", True, 0, Combine.ADD, False,
            frozenset({Keep.LARGEST, Keep.BINNED}), lambda scene: scene.collision is not None,
            "COLLISION != COLLISION_NONE", _deposits),
)
BY_ID: dict[int, Counter] = {row.id: row for row in COUNTERS}
BY_NAME: dict[str, Counter] = {row.name: row for row in COUNTERS}

Counts = dict[str, tuple[int, ...]]  # a frame's counters by name: the rows that were counted


def counted_rows(scene: Scene) -> tuple[Counter, ...]:
    """The rows `scene` counts, in table order."""
    return tuple(row for row in COUNTERS if row.counted(scene))


def widths(scene: Scene) -> dict[int, int]:
    """Per id of each row `scene` counts, its number of values: what its walls report."""
    return {row.id: row.width(scene) for row in counted_rows(scene)}


def twin_counts(scene: Scene, step: TwinStep) -> Counts:
    """Every row `scene` counts, as a twin computes it from `step`."""
    return {row.name: row.twin(step) for row in counted_rows(scene)}


def entries(counts: Mapping[str, tuple[int, ...]]) -> tuple[tuple[int, tuple[int, ...]], ...]:
    """A report's counter tail from counts by name: (id, values) in table order."""
    return tuple((row.id, tuple(counts[row.name])) for row in COUNTERS if row.name in counts)


def _check_table() -> None:
    ids, names = [row.id for row in COUNTERS], [row.name for row in COUNTERS]
    assert len(set(ids)) == len(ids) and len(set(names)) == len(names), "ids, names: once"
    for row in COUNTERS:
        assert 1 <= row.id <= MAX_ID and row.name.isidentifier() and row.name.islower()
        assert row.per_class or 1 <= row.values <= MAX_VALUES
        assert row.events or Keep.TOTAL not in row.keeps, f"{row.name}: a level has no total"
        assert bool(row.needs) == row.in_pass, f"{row.name}: a switch needs a condition"


_check_table()

__all__ = ["BY_ID", "BY_NAME", "COUNTERS", "Combine", "Counter", "Counts",
           "Keep", "TwinStep", "counted_rows", "entries", "twin_counts", "widths"]
