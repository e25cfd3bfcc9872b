"""cavesim: a GPU particle simulation kept bit-identical across the walls of a CAVE.

The library, three layers, each importing only the ones below it (tests/docs/test_layers.py
checks it):
  core   (cavesim.core)  no GL: scenes, CAVE geometry, frame inputs, records, scene
                         drivers, the clock, the wire, the float64 and portable twins;
  gpu    (cavesim.gpu)   the OpenGL engine, its shaders, the wall renderer;
  tools  (cavesim.tools) offline tools: engine benchmark, numerics, stability, doctor,
                         frame-log replay, reports.
The programs that make a CAVE (master, wall node, launcher, harness, tracker bridge, the
`cavesim` command line) are the package `nodes`, built on this one.
"""
