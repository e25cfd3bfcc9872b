"""The GPU's side of the counter table (cavesim/core/counters.py): one storage buffer of uints
holding every counter a scene counts, and the defines that tell the particle pass where.

The buffer's layout follows from the table alone: the rows the particle pass combines into
first, in table order, a per-class row with room for MAX_PARTICLE_CLASSES values, each at a
constant offset, then the rows copied from the passes' own counts. Only the switches vary
with the scene: `COUNT_<NAME>` where it counts a row (`scene_counter_defines`), each
allowed only where the row's `needs` hold (`RULES`); the offsets (`<NAME>_AT`) and
`COUNTING` (any switch on) are pasted into the pass after its defines (`PREAMBLE`). Each
frame the buffer is cleared before the passes (`start_frame`, bound at BINDING where
shaders/include/counters.glsl declares it), the passes' drops are copied in on the GPU
after them (`copy_passes_counts`), and the host reads it after the checksum's wait, so the
read costs a copy, not a stall (`read`). A scene that counts nothing gets no buffer.

The compute path always counts. The GS/TF path steps in its vertex stage, which GL 4.3 need
not let write storage: it counts the pass's rows where the context offers
GL_MAX_VERTEX_SHADER_STORAGE_BLOCKS >= 1, read from the context (a recorded profile without
the value counts as offering none); elsewhere those rows are not counted (`counted_here`),
and the copied ones are.
"""

from __future__ import annotations

from collections.abc import Callable, Collection, Mapping

import moderngl
import numpy as np

from cavesim.core.counters import COUNTERS, Counter, Counts, counted_rows
from cavesim.core.features.rules import Rule
from cavesim.core.limits import MAX_PARTICLE_CLASSES
from cavesim.core.scene.model import Engine, Scene
from cavesim.gpu.engine.drops import DROPPED

BINDING = 6  # the storage-buffer binding counters.glsl declares
PASS_ROWS = tuple(row for row in COUNTERS if row.in_pass)
COPIED_FROM = {"capacity_drops": DROPPED}  # a copied row's byte offset in the passes' counts


def switch(row: Counter) -> str:
    """The define that compiles a row's counting in: COUNT_<NAME>."""
    return f"COUNT_{row.name.upper()}"


def offset(row: Counter) -> str:
    """The define naming a row's first uint in the buffer: <NAME>_AT."""
    return f"{row.name.upper()}_AT"


def width(row: Counter) -> int:
    """A row's room in the buffer: its values, or a value per class of the most a scene has."""
    return MAX_PARTICLE_CLASSES if row.per_class else row.values


SWITCHES = tuple(switch(row) for row in PASS_ROWS)
# Each pass row's first uint: constant, so that only the switches vary with the scene
OFFSETS = {row.name: sum(width(r) for r in PASS_ROWS[:i]) for i, row in enumerate(PASS_ROWS)}
PASS_UINTS = sum(width(row) for row in PASS_ROWS)
# The particle pass's counter defines, with the values each may take: a switch per pass row
DEFINES: dict[str, tuple[int, ...]] = {switch(row): (0, 1) for row in PASS_ROWS}
# ... on only where the pass can count its row (the gate's validity and the pass's #errors)
RULES: tuple[Rule, ...] = tuple(
    Rule(switch(row), row.needs, "counters", f"{row.name} is counted only where {row.needs}")
    for row in PASS_ROWS)
# What follows from the switches and the table, pasted into the particle pass after its
# defines: COUNTING (any switch on) and each row's offset
PREAMBLE = "".join([f"#define COUNTING ({' || '.join(SWITCHES) or '0'})\n",
                    *(f"#define {offset(row)} {OFFSETS[row.name]}\n" for row in PASS_ROWS)])


def stage_counts(engine: Engine, info: Mapping[str, object]) -> bool:
    """Whether the stage that steps the particles on `engine` may write storage."""
    return engine is Engine.COMPUTE or int(info.get("GL_MAX_VERTEX_SHADER_STORAGE_BLOCKS")
                                           or 0) >= 1


def counted_here(scene: Scene, engine: Engine, info: Mapping[str, object]) -> tuple[str, ...]:
    """The rows the scene counts on `engine` in a context with `info`, by name."""
    storage = stage_counts(engine, info)
    return tuple(row.name for row in counted_rows(scene) if storage or not row.in_pass)


def scene_counter_defines(scene: Scene) -> dict[str, int]:
    """The particle pass's counter switches: on for each row the scene counts."""
    counted = {row.name for row in counted_rows(scene)}
    return {switch(row): int(row.name in counted) for row in PASS_ROWS}


class CounterBuffer:
    """The counters of one scene on one context (see the module docstring)."""

    def __init__(self, ctx: moderngl.Context, scene: Scene,
                 buffer: Callable[[str, int], moderngl.Buffer]) -> None:
        rows = counted_rows(scene)
        copied = [row for row in COUNTERS if not row.in_pass]
        self._ctx = ctx
        self.widths = {row.name: row.width(scene) for row in rows}
        self.offsets = {**OFFSETS, **{row.name: PASS_UINTS + sum(width(r) for r in copied[:i])
                                      for i, row in enumerate(copied)}}
        self.uints = PASS_UINTS + sum(width(row) for row in copied)
        # a scene that counts nothing gets no buffer
        self.buffer = buffer("counters", 4 * self.uints) if rows else None
        self._zeros = bytes(4 * self.uints)

    def start_frame(self) -> None:
        """Zero the counters and bind them where the particle pass combines into them."""
        if self.buffer is not None:
            self.buffer.write(self._zeros)
            self.buffer.bind_to_storage_buffer(BINDING)

    def copy_passes_counts(self, counts: moderngl.Buffer) -> None:
        """Copy the frame's copied rows from the passes' counts buffer, on the GPU."""
        if self.buffer is None:
            return
        self._ctx.memory_barrier(moderngl.BUFFER_UPDATE_BARRIER_BIT)
        for name, read_offset in COPIED_FROM.items():
            if name in self.widths:
                self._ctx.copy_buffer(self.buffer, counts, size=4, read_offset=read_offset,
                                      write_offset=4 * self.offsets[name])

    def read(self, counted: Collection[str]) -> Counts:
        """The last frame's rows `counted`, from one read of the buffer."""
        if self.buffer is None:
            return {}
        self._ctx.memory_barrier(moderngl.BUFFER_UPDATE_BARRIER_BIT)
        words = np.frombuffer(self.buffer.read(), "<u4")
        return {name: tuple(words[self.offsets[name]:self.offsets[name] + n].tolist())
                for name, n in self.widths.items() if name in counted}

    def zeros(self, counted: Collection[str]) -> Counts:
        """Rows `counted`, each value 0 (a state loaded, not stepped into)."""
        return {name: (0,) * width for name, width in self.widths.items() if name in counted}
