"""The state checksum's hash tree without GL: its shape (which words each block covers), its
numpy twin, and the ring of fold-1 items a node keeps per frame; beside it, the
cryptographic digest of records a resync's confirmation compares. The GPU passes
(`cavesim.gpu.engine.checksum`), the master's desync forensics and a node's delta resync
all read the same tree through these."""
