"""The cryptographic digest a resync's confirmation compares: SHA-256 of records' bytes.

The per-frame checksum (`twin.py`) is fast and proves that honest walls agree; it proves
nothing against a sender that builds a state to match it (two particles traded inside one
invocation keep every sum). Before a node commits a state it received, a second wall that
holds the agreed state hashes the same records from its own GPU state and signs the digest;
the receiver hashes what it received. Both sides feed this one definition: which stream,
how many records, the indices when a question names them (else the whole live stream), then
the records' bytes in order. SHA-256 rather than BLAKE2b: hosts hash it in hardware (SHA-NI,
ARMv8), twice BLAKE2b's speed here (docs/2026-12-07-resync-confirmation.md).
"""

from __future__ import annotations

import hashlib
import struct

import numpy as np

DIGEST_BYTES = 32  # SHA-256
_DOMAIN = b"cavesim records\0"  # first: no other digest of ours hashes the same bytes
_PREFIX = struct.Struct("<BBI")  # stream, named (1) or the whole stream (0), record count


class RecordsDigest:
    """The digest of `count` records of `stream`: those `indices` names (ascending), or, when
    None, the whole live stream; fed their bytes in order by `update`."""

    def __init__(self, stream: int, count: int, indices: np.ndarray | None = None) -> None:
        if indices is not None and len(indices) != count:
            raise ValueError(f"{count} records named by {len(indices)} indices")
        self._hash = hashlib.sha256(_DOMAIN)
        self._hash.update(_PREFIX.pack(stream, indices is not None, count))
        if indices is not None:
            self._hash.update(np.asarray(indices, dtype="<u4").tobytes())

    def update(self, data: bytes) -> None:
        self._hash.update(data)

    def digest(self) -> bytes:
        return self._hash.digest()


def records_digest(stream: int, count: int, data: bytes,
                   indices: np.ndarray | None = None) -> bytes:
    """The digest of records given whole (see `RecordsDigest`)."""
    digest = RecordsDigest(stream, count, indices)
    digest.update(data)
    return digest.digest()
