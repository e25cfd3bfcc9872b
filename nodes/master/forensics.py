"""Desync forensics: which records, which fields, by how much and since when two nodes'
states differ, found by comparing their checksum trees top-down.

On a divergence the master (before it resyncs the odd node) asks the odd node and a
healthy one for the tree top (fold-2 items, with seed and counts), compares, asks for the
fold-1 items (blocks) under the differing fold-2 items, then for the invocation sums of
the differing blocks, maps the differing invocations to the records whose words they
summed (cavesim/core/digest/shape.py), fetches only those records from both nodes and
diffs them field by field (cavesim/core/record_diff.py). At 1M particles a one-bit
difference costs ~160 B + 2 KB + 1 KB of tree and 256 records (10 KB) per node.

Since when: each node keeps the fold-1 items of its last HISTORY_FRAMES frames; the master
asks both for that history and walks back from the divergence while the blocks that may
have held a differing record differ. A particle record only moves toward the stream's start
(particles before it die, new ones are appended after), so at an earlier frame it was in
its block or a later one of the particle stream; an emitter record never moves.

Everything asked is bounded: at most MAX_EXAMINED differing blocks per stream are followed
down to their records, of which at most MAX_BLOCK_INDICES are fetched; MAX_REPORTED records
are written (the rest counted); a history covers at most HISTORY_WIDTH blocks.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from cavesim.core.digest.shape import (
    EMITTERS,
    FOLD,
    ITEM_WORDS,
    PARTICLES,
    STREAMS,
    WORKGROUP_SIZE,
    Plan,
    block_of_record,
    children,
    invocation_records,
    plan,
)
from cavesim.core.errors import CavesimError
from cavesim.core.output import writing
from cavesim.core.record_diff import FieldDifference, differences
from cavesim.core.records import EMITTER_DTYPE, PARTICLE_DTYPE
from cavesim.core.wire.payloads.state_transfer import (
    MAX_BLOCK_INDICES,
    BlockQuery,
    BlockReply,
    BlockRequest,
)

MAX_EXAMINED = 16  # differing blocks per stream followed down to their records
MAX_REPORTED = 64  # differing records written per stream (the rest are counted)
HISTORY_WIDTH = 4096  # fold-1 items of a history question: 64 frames x 4096 x 16 B = 4 MiB
FORENSICS_SECONDS = 20.0  # for all the questions of one investigation
DTYPES = (PARTICLE_DTYPE, EMITTER_DTYPE)
RECORD_NAMES = ("particle", "emitter")

Ask = Callable[[str, BlockRequest], BlockReply | None]  # the master link's ask_blocks


class ForensicsError(CavesimError):
    """A node did not answer (or answered wrongly) a question the forensics needed."""


@dataclass(frozen=True)
class Side:
    """One node of the comparison and the checksum of the state it reported."""

    node: str
    digest: str


class _Questions:
    """Asks the odd node and the reference node the same question about their states."""

    def __init__(self, frame: int, odd: Side, reference: Side, ask: Ask) -> None:
        self.frame, self.sides, self.ask = frame, (odd, reference), ask
        self.bytes = 0
        self.deadline = time.monotonic() + FORENSICS_SECONDS

    def both(self, query: BlockQuery, part: int, indices: tuple[np.ndarray, np.ndarray]
             ) -> tuple[BlockReply, BlockReply]:
        return tuple(self.one(side, query, part, wanted)
                     for side, wanted in zip(self.sides, indices, strict=True))

    def items(self, level: int, indices: tuple[np.ndarray, np.ndarray]
              ) -> tuple[np.ndarray, np.ndarray]:
        """Items `indices` of tree level `level` of both states (none asked: none)."""
        if not len(indices[0]):
            empty = np.zeros((0, ITEM_WORDS[level]), np.uint32)
            return empty, empty
        return tuple(_rows(r, ITEM_WORDS[level])
                     for r in self.both(BlockQuery.TREE, level, indices))

    def one(self, side: Side, query: BlockQuery, part: int, indices: np.ndarray) -> BlockReply:
        """The reply about `side`'s state, asked in pages of MAX_BLOCK_INDICES indices."""
        pages = [indices[i:i + MAX_BLOCK_INDICES]
                 for i in range(0, len(indices), MAX_BLOCK_INDICES)] or [indices]
        replies = []
        for page in pages:
            if time.monotonic() > self.deadline:
                raise ForensicsError(f"the questions took longer than {FORENSICS_SECONDS:g} s")
            reply = self.ask(side.node, BlockRequest(self.frame, side.node, side.digest, query,
                                                     part, tuple(int(i) for i in page)))
            if reply is None:
                raise ForensicsError(f"{side.node} did not answer a {query.name} question of "
                                     f"frame {self.frame}")
            self.bytes += len(reply.data)
            replies.append(reply)
        return replies[0] if len(replies) == 1 else _joined(replies)


def _joined(replies: list[BlockReply]) -> BlockReply:
    first = replies[0]
    return BlockReply(first.frame, first.node, first.query, first.part, first.seed,
                      first.particles, first.emitters, b"".join(r.data for r in replies),
                      first.history)


def _rows(reply: BlockReply, words: int) -> np.ndarray:
    return np.frombuffer(reply.data, "<u4").reshape(-1, words)


def investigate(frame: int, odd: Side, reference: Side, ask: Ask) -> dict:
    """The forensic report of frame `frame`: `odd`'s state against `reference`'s."""
    questions = _Questions(frame, odd, reference, ask)
    none = np.zeros(0, np.int64)
    tops = questions.both(BlockQuery.TREE, 2, (none, none))
    counts = [(t.particles, t.emitters) for t in tops]
    shapes = [plan(*c) for c in counts]
    report: dict = {
        "frame": frame, "odd_node": odd.node, "reference_node": reference.node,
        "checksums": {"odd": odd.digest, "reference": reference.digest},
        "live": {"odd": dict(zip(STREAMS, counts[0], strict=True)),
                 "reference": dict(zip(STREAMS, counts[1], strict=True))},
        "seeds_differ": tops[0].seed != tops[1].seed,
    }
    blocks = _differing_blocks(questions, tops, shapes)
    streams, found = [], []
    for stream in (PARTICLES, EMITTERS):
        if blocks[stream] or counts[0][stream] != counts[1][stream]:
            entry, diffs = _stream(questions, stream, blocks[stream], counts, shapes)
            streams.append(entry)
            found += [(stream, d) for d in diffs]
    report["streams"] = streams
    if found:
        _since(questions, found, streams, shapes, report)
    report["bytes_fetched"] = questions.bytes
    report["summary"] = summary_line(report)
    return report


def _differing_blocks(questions: _Questions, tops: tuple[BlockReply, BlockReply],
                      shapes: list[Plan]) -> dict[int, list[int]]:
    """Per stream, its work groups whose blocks (fold-1 items) differ, ascending."""
    found: dict[int, list[int]] = {PARTICLES: [], EMITTERS: []}
    if shapes[0] == shapes[1]:  # the trees pair item by item: down from fold 2
        shape = shapes[0]
        top = [_rows(t, ITEM_WORDS[2]) for t in tops]
        differing = np.flatnonzero((top[0] != top[1]).any(axis=1))
        kids = np.array([b for i in differing for b in children(2, int(i), shape.items[1])],
                        np.int64)
        level_1 = questions.items(1, (kids, kids))
        for block in kids[(level_1[0] != level_1[1]).any(axis=1)]:
            stream, group = shape.stream_group(int(block))
            found[stream].append(group)
        return found
    for stream in (PARTICLES, EMITTERS):  # the counts moved the blocks: stream by stream
        groups = [s.stream_groups(stream) for s in shapes]
        common = np.arange(min(groups))
        level_1 = questions.items(1, tuple(
            np.array([s.block(stream, g) for g in common], np.int64) for s in shapes))
        found[stream] = [*common[(level_1[0] != level_1[1]).any(axis=1)].tolist(),
                         *range(min(groups), max(groups))]
    return found


def _stream(questions: _Questions, stream: int, groups: list[int],
            counts: list[tuple[int, int]], shapes: list[Plan]
            ) -> tuple[dict, list[FieldDifference]]:
    """One stream's differing invocations, records and fields (the first MAX_EXAMINED
    differing blocks of the records both nodes hold)."""
    live = min(c[stream] for c in counts)
    both_hold = [g for g in groups if g < min(s.stream_groups(stream) for s in shapes)]
    examined = both_hold[:MAX_EXAMINED]
    sums = questions.items(0, tuple(np.array(
        [s.block(stream, g) * FOLD + t for g in examined for t in range(WORKGROUP_SIZE)],
        np.int64) for s in shapes))
    invocations = np.flatnonzero((sums[0] != sums[1]).any(axis=1))
    records = np.unique(np.concatenate([np.zeros(0, np.int64), *(
        invocation_records(stream, examined[i // WORKGROUP_SIZE], i % WORKGROUP_SIZE, live)
        for i in invocations)]))[:MAX_BLOCK_INDICES]  # one question's worth: 640 KiB
    diffs: list[FieldDifference] = []
    if len(records):
        fetched = questions.both(BlockQuery.RECORDS, stream, (records, records))
        diffs = differences(DTYPES[stream], records, fetched[0].data, fetched[1].data)
    by_record = sorted({d.record for d in diffs})
    entry = {"stream": STREAMS[stream],
             "live": {"odd": counts[0][stream], "reference": counts[1][stream]},
             "differing_blocks": len(groups), "examined_blocks": examined,
             "differing_invocations": len(invocations), "records_compared": len(records),
             "differing_records": len(by_record),
             "records": [{"index": r, "fields": [d.to_json() for d in diffs if d.record == r]}
                         for r in by_record[:MAX_REPORTED]]}
    return entry, diffs


def _since(questions: _Questions, found: list[tuple[int, FieldDifference]],
           streams: list[dict], shapes: list[Plan], report: dict) -> None:
    """Fill in each reported record's `first_differing_frame` from both nodes' history of
    the blocks that may have held it."""
    particle_blocks = [block_of_record(PARTICLES, d.record) for s, d in found if s == PARTICLES]
    level_1 = min(s.items[1] for s in shapes)
    first = 0 if level_1 <= HISTORY_WIDTH else min(particle_blocks, default=0)
    indices = np.arange(first, min(first + HISTORY_WIDTH, level_1), dtype=np.int64)
    histories = [_history(r, len(indices))
                 for r in questions.both(BlockQuery.HISTORY, 1, (indices, indices))]
    frames = sorted(set(histories[0]) & set(histories[1]), reverse=True)
    report["history"] = {"frames": [frames[-1], frames[0]] if frames else [],
                         "blocks": [int(first), int(first + len(indices))]}
    for entry in streams:
        stream = STREAMS.index(entry["stream"])
        for record in entry["records"]:
            since, exact = _first_differing(stream, record["index"], frames, histories,
                                            int(first), len(indices))
            record["first_differing_frame"] = since
            record["first_differing_frame_exact"] = exact


def _history(reply: BlockReply, width: int) -> dict[int, tuple[Plan, np.ndarray]]:
    """frame -> (the shape of that frame's tree, its fold-1 items asked for)."""
    items = _rows(reply, ITEM_WORDS[1]).reshape(len(reply.history), width, ITEM_WORDS[1])
    return {h.frame: (plan(h.particles, h.emitters), items[i])
            for i, h in enumerate(reply.history)}


def _first_differing(stream: int, record: int, frames: list[int], histories: list[dict],
                     first: int, width: int) -> tuple[int | None, bool]:
    """The earliest frame from which, up to the divergence, the blocks that may have held
    `record` differed in every frame; and whether that is exact (the frame before it is
    known to agree) rather than the oldest the history could tell."""
    since = None
    for frame in frames:  # newest first
        if since is not None and frame != since - 1:
            return since, False  # a frame missing from a ring
        differs = _blocks_differ(stream, record, [h[frame] for h in histories], first, width)
        if not differs:
            return since, differs is False and since is not None
        since = frame
    return since, False


def _blocks_differ(stream: int, record: int, both: list[tuple[Plan, np.ndarray]],
                   first: int, width: int) -> bool | None:
    """Whether, in one frame, the blocks that may have held `record` differ between the
    nodes (None: none known to differ, but some are outside the history asked for)."""
    start = block_of_record(stream, record)
    end = max(s.stream_groups(stream) for s, _ in both) if stream == PARTICLES else start + 1
    unknown = False
    for group in range(start, end):
        values = [_item(shape, items, stream, group, first, width) for shape, items in both]
        if None in values:
            unknown = True
        elif values[0] != values[1]:
            return True
    return None if unknown else False


def _item(shape: Plan, items: np.ndarray, stream: int, group: int, first: int,
          width: int) -> bytes | None:
    """Block `group` of `stream` in one node's frame: its bytes, b"" if that state had no
    such block, None if it lies outside the history asked for."""
    if group >= shape.stream_groups(stream):
        return b""
    block = shape.block(stream, group) - first
    return items[block].tobytes() if 0 <= block < width else None


def summary_line(report: dict) -> str:
    """One line a person reads in the log: the first differing field, or why none."""
    head = f"frame {report['frame']}: {report['odd_node']} differs from " \
           f"{report['reference_node']}"
    if "error" in report:
        return f"{head}; forensics stopped: {report['error']}"
    live = report["live"]
    for stream in STREAMS:
        if live["odd"][stream] != live["reference"][stream]:
            head += f" ({stream}: {live['odd'][stream]} vs {live['reference'][stream]} live)"
    entries = [e for e in report["streams"] if e["records"]]
    if not entries:
        why = "seeds differ" if report["seeds_differ"] else \
            "no differing record found among those both hold"
        return f"{head}: {why}"
    entry = entries[0]
    record = entry["records"][0]
    field = record["fields"][0]
    stream = STREAMS.index(entry["stream"])
    odd, ref = field["odd"], field["reference"]
    unit = "ULP" if field["type"].startswith("float") else "apart"
    since = record.get("first_differing_frame")
    more = sum(len(r["fields"]) for e in entries for r in e["records"]) - 1
    return (f"{head} in {RECORD_NAMES[stream]} {record['index']} {field['field']}: "
            f"{odd['value']} ({odd['bits']}) vs {ref['value']} ({ref['bits']}), "
            f"{field['distance']} {unit}"
            + (f", since frame {since}" if since is not None else "")
            + (f" (and {more} more field(s))" if more else ""))


def failed_report(frame: int, odd: Side, reference: Side, error: str) -> dict:
    report = {"frame": frame, "odd_node": odd.node, "reference_node": reference.node,
              "checksums": {"odd": odd.digest, "reference": reference.digest}, "error": error}
    report["summary"] = summary_line(report)
    return report


def write_report(folder: Path, report: dict, others: list[dict]) -> Path:
    """divergences/frame_<k>.json in the run's folder: the first odd node's report, and
    any other odd node's under `other_odd_nodes`."""
    path = folder / "divergences" / f"frame_{report['frame']}.json"
    with writing(path):
        path.parent.mkdir(parents=True, exist_ok=True)
        content = {**report, **({"other_odd_nodes": others} if others else {})}
        path.write_text(json.dumps(content, indent=2) + "\n")
    return path
