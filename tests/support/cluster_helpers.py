"""Hypothesis strategies for wire messages and byte mutations, shared by the wire tests and
the fuzz test of a running cluster.

`messages()` draws any valid message (every kind, edge values included); `Mutation` is a
change of a byte string chosen before the bytes are known (the cluster fuzzer mutates
messages it captures during the run), and never gives back the bytes it was handed.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from hypothesis import strategies as st

from cavesim.core.counters import BY_ID, MAX_ID, MAX_VALUES
from cavesim.core.drift import SAMPLE_DTYPE, DriftSample
from cavesim.core.frame_cost import PHASES
from cavesim.core.limits import MAX_PARTICLE_CLASSES, MAX_PARTICLES
from cavesim.core.records import PARTICLE_BYTES
from cavesim.core.wire.credentials import ED25519_BYTES, SECRET_BYTES, of_master
from cavesim.core.wire.payloads.from_master import MAX_PARAMS, Command, ControlMessage, FrameMessage
from cavesim.core.wire.payloads.from_nodes import (
    MAX_TEXT,
    DisplayMessage,
    InfoMessage,
    Phase,
    ReportMessage,
    Status,
)
from cavesim.core.wire.payloads.poses import HeadState, TrackingMessage, WandState
from cavesim.core.wire.payloads.state_transfer import (
    MAX_CHUNK_PARTICLES,
    SnapshotChunk,
    SnapshotHeader,
)
from cavesim.gpu.engine import EMITTER_DTYPE, FrameInput

U32 = 2**32 - 1
U64 = 2**64 - 1
MAX_MATRIX_ENTRY = 2**24 - 1  # validate_transform: integer entries below 2**24

names = st.from_regex(r"[A-Za-z0-9_-]{1,32}", fullmatch=True)
frame_numbers = st.integers(0, U64)
f32 = st.floats(width=32, allow_nan=False, allow_infinity=False)
dts = st.floats(min_value=0.0, width=32, allow_infinity=False)  # subnormals and max included
credential_sets = st.builds(of_master, st.binary(min_size=SECRET_BYTES, max_size=SECRET_BYTES),
                            st.binary(min_size=ED25519_BYTES, max_size=ED25519_BYTES))


@st.composite
def transforms(draw) -> np.ndarray:
    """A random-texture transform that FrameInput accepts: integers, last row [0, 0, 1]."""
    top = draw(st.lists(st.integers(-MAX_MATRIX_ENTRY, MAX_MATRIX_ENTRY), min_size=6,
                        max_size=6))
    return np.array([top[:3], top[3:], [0, 0, 1]], dtype=np.float32)


wands = st.builds(WandState, st.tuples(f32, f32, f32), st.tuples(f32, f32, f32, f32),
                  st.integers(0, U32), st.tuples(f32, f32, f32, f32))

heads = st.builds(HeadState, st.tuples(f32, f32, f32), st.tuples(f32, f32, f32, f32))

frame_messages = st.builds(
    FrameMessage, frame_numbers, st.builds(FrameInput, dts, transforms()), wands,
    st.lists(f32, max_size=MAX_PARAMS).map(tuple), heads)

digests = st.binary(min_size=16, max_size=16).map(bytes.hex)


@st.composite
def report_messages(draw) -> ReportMessage:
    """A report, with a drift sample (arbitrary bytes: NaN and all) of at most its live
    count or without one, and a counter tail of known and unknown ids."""
    particles = draw(st.integers(0, U32))
    size = draw(st.none() | st.integers(0, min(particles, 8)))
    sample = None if size is None else DriftSample(draw(st.binary(
        min_size=size * SAMPLE_DTYPE.itemsize, max_size=size * SAMPLE_DTYPE.itemsize)))
    return ReportMessage(draw(frame_numbers), draw(names), draw(digests), particles,
                         draw(st.integers(0, U32)),
                         tuple(draw(st.lists(st.integers(0, U32), min_size=len(PHASES),
                                             max_size=len(PHASES)))),
                         draw(st.integers(0, U32)), draw(st.sampled_from(Status)), sample,
                         draw(counter_tails()))


@st.composite
def counter_tails(draw) -> tuple[tuple[int, tuple[int, ...]], ...]:
    """A report's counters: known rows with their number of values (a per-class one with
    1 to MAX_PARTICLE_CLASSES) and ids no row has, with any number up to MAX_VALUES."""
    ids = draw(st.lists(st.sampled_from(tuple(BY_ID)) | st.integers(1, MAX_ID), unique=True,
                        max_size=6))
    tail = []
    for id_ in ids:
        row = BY_ID.get(id_)
        width = (draw(st.integers(1, MAX_PARTICLE_CLASSES)) if row.per_class else row.values) \
            if row is not None else draw(st.integers(0, MAX_VALUES))
        tail.append((id_, tuple(draw(st.lists(st.integers(0, U32), min_size=width,
                                              max_size=width)))))
    return tuple(tail)


optional_names = st.just("") | names
control_messages = st.builds(ControlMessage, frame_numbers, st.sampled_from(Command),
                             optional_names, optional_names)


def records(dtype: np.dtype, max_count: int) -> st.SearchStrategy[np.ndarray]:
    """Arrays of `dtype` holding arbitrary bytes (NaN payloads and all)."""
    return st.integers(0, max_count).flatmap(
        lambda n: st.binary(min_size=n * dtype.itemsize, max_size=n * dtype.itemsize)).map(
        lambda raw: np.frombuffer(raw, dtype).copy())


snapshot_headers = st.builds(SnapshotHeader, frame_numbers, st.integers(0, U64),
                             st.integers(0, MAX_PARTICLES),
                             st.integers(1, MAX_CHUNK_PARTICLES), digests,
                             records(EMITTER_DTYPE, 4))
snapshot_chunks = st.builds(SnapshotChunk, frame_numbers, st.integers(0, MAX_PARTICLES - 1),
                            st.integers(1, 4).flatmap(lambda n: st.binary(
                                min_size=n * PARTICLE_BYTES, max_size=n * PARTICLE_BYTES)))
snapshot_messages = snapshot_headers | snapshot_chunks


tracking_messages = st.builds(TrackingMessage, frame_numbers, heads, wands)

texts = st.text(st.characters(min_codepoint=0x20, max_codepoint=0x7E), max_size=MAX_TEXT)
info_messages = st.builds(InfoMessage, frame_numbers, names, st.integers(0, 2**16 - 1),
                          st.booleans(), texts, texts, texts, st.booleans())

display_messages = st.builds(DisplayMessage, frame_numbers, names, st.sampled_from(Phase),
                             st.integers(0, U64))


def messages() -> st.SearchStrategy:
    """Any valid message of any kind."""
    return st.one_of(frame_messages, report_messages(), control_messages, snapshot_messages,
                     tracking_messages, info_messages, display_messages)


MUTATIONS = ("flip", "insert", "delete", "truncate")


@dataclass(frozen=True)
class Mutation:
    """One change of a byte string: at `where` (a fraction of its length) `op` with `value`.

    flip: XOR the byte with value (1..255); insert: put value there; delete: drop the byte;
    truncate: cut the bytes off there. The result always differs from the input.
    """

    op: str
    where: float  # in [0, 1)
    value: int  # 1..255

    def apply(self, data: bytes) -> bytes:
        if not data:
            return bytes([self.value])
        at = min(int(self.where * len(data)), len(data) - 1)
        if self.op == "flip":
            return data[:at] + bytes([data[at] ^ self.value]) + data[at + 1:]
        if self.op == "insert":
            return data[:at] + bytes([self.value]) + data[at:]
        if self.op == "delete":
            return data[:at] + data[at + 1:]
        if self.op == "truncate":
            return data[:at]
        raise ValueError(f"mutation op must be one of {MUTATIONS}, got {self.op!r}")


mutations = st.builds(Mutation, st.sampled_from(MUTATIONS),
                      st.floats(0.0, 1.0, exclude_max=True), st.integers(1, 255))


def mutate(data: bytes, changes: list[Mutation]) -> bytes:
    for change in changes:
        data = change.apply(data)
    return data
