"""The tools on top: the `cavesim` command line and what its commands run (benchmarks,
numerics, stability, doctor, replay) and report. Built on every layer below."""
