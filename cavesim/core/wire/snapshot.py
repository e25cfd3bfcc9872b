"""A node's state on the wire as a stream: a header, then the particle stream in chunks.

The source answers one state query with a SnapshotHeader (frame, seed, counts, chunk size,
the state's checksum, the emitters) and then the chunks, read from its GPU buffer one at a
time, so neither side ever holds the whole state in one message. The receiver places each
chunk by its index (zenoh delivers one query's replies in order over a link; nothing here
relies on it), refuses strays and duplicates, and commits only once every chunk is in and
the staged state has the announced checksum.
"""

from __future__ import annotations

from collections.abc import Iterator

from cavesim.core.errors import ProtocolError
from cavesim.core.records import PARTICLE_BYTES
from cavesim.core.wire.payloads.state_transfer import SnapshotChunk, SnapshotHeader

CHUNK_PARTICLES = 4 * 2**20 // PARTICLE_BYTES  # 104,857 particles: a 4 MiB reply
TRANSFER_BASE = 10.0  # s: reaching the source and its first reply
# The slowest a snapshot is assumed to stream, in bytes/s: a fifth of 1 GbE, an eighth of
# what loopback gave with HMACs and llvmpipe's buffer writes (216 MB/s for 134 MB, docs/design.md).
TRANSFER_RATE = 25e6


def transfer_seconds(particles: int) -> float:
    """How long fetching a snapshot of `particles` may take: the node's deadline; the
    master's is this plus the way of the RESYNC command and the report."""
    return TRANSFER_BASE + particles * PARTICLE_BYTES / TRANSFER_RATE


def chunk_spans(particles: int, chunk_particles: int) -> Iterator[tuple[int, int, int]]:
    """(index, first particle, particle count) of each chunk of a stream of `particles`."""
    for index, first in enumerate(range(0, particles, chunk_particles)):
        yield index, first, min(chunk_particles, particles - first)


class SnapshotAssembly:
    """The receiver's account of one snapshot: which chunks are in, and where each goes.

    Every refusal is a ProtocolError with a reason the receiver counts.
    """

    def __init__(self, header: SnapshotHeader, capacity: int, emitters: int) -> None:
        if header.particles > capacity or len(header.emitters) != emitters:
            raise ProtocolError("wrong-counts", f"a snapshot of {header.particles} particles "
                                                f"and {len(header.emitters)} emitters; this "
                                                f"node holds at most {capacity} particles "
                                                f"and exactly {emitters} emitters")
        self.header = header
        self._received: set[int] = set()

    def place(self, chunk: SnapshotChunk) -> int:
        """The first particle of `chunk`, once it is known to belong here exactly once."""
        header = self.header
        if chunk.frame != header.frame:
            raise ProtocolError("wrong-frame", f"chunk {chunk.index} of frame {chunk.frame} "
                                               f"in a snapshot of frame {header.frame}")
        if chunk.index >= header.chunks:
            raise ProtocolError("chunk-out-of-range", f"chunk {chunk.index} of a snapshot of "
                                                      f"{header.chunks} chunks")
        if chunk.index in self._received:
            raise ProtocolError("duplicate-chunk", f"chunk {chunk.index} came twice")
        first = chunk.index * header.chunk_particles
        expected = min(header.chunk_particles, header.particles - first) * PARTICLE_BYTES
        if len(chunk.data) != expected:
            raise ProtocolError("bad-chunk-size", f"chunk {chunk.index} has {len(chunk.data)} "
                                                  f"bytes, expected {expected}")
        self._received.add(chunk.index)
        return first

    def check_complete(self) -> None:
        """ProtocolError unless every chunk of the snapshot is in."""
        chunks = self.header.chunks
        if len(self._received) < chunks:
            first = next(i for i in range(chunks) if i not in self._received)
            raise ProtocolError("missing-chunks", f"{chunks - len(self._received)} of {chunks} "
                                                  f"chunks never came, the first is {first}")
