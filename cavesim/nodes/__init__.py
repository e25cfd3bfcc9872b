"""The processes: the master (the clock, the barrier, the vote), the wall node (its GL
context, step, checksum, pictures), the local launcher, the consistency harness and the
DTrack tracker bridge.
Built on `cavesim.core` and `cavesim.gpu`; the master needs the core alone."""
