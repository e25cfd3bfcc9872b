"""The programs that make a CAVE, built on the library `cavesim` (nothing there imports
this package; `python -m cavesim` is the command line's own entry point).

One folder per process: `master/`, `wall/`, `check/` (the consistency harness and its rogue
peer), `tracker/` (the DTrack bridge), `launch/` (wall processes on this machine), plus
`cluster_bench/` (benchmarks that run clusters) and `gpu_check/` (a new GPU node's check).
`master/process.py`, `wall/process.py` are the same role in parallel folders: the process's
main loop; so are `master/settings.py`, `wall/settings.py`: what the process is told to
run. Beside them: `cli.py`, `arguments.py` and `commands/` (the command line), and what
more than one process obeys: `lockstep.py` (the lock-step's rules), `blocks.py` (block
requests: walls answer, the master and resyncing walls ask), `faults.py` (what the harness
injects), `mixed_hardware.py` (the tolerance mode's flags).
"""
