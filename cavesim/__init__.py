"""cavesim: a GPU particle simulation kept bit-identical across the walls of a CAVE.

Four layers, each importing only the ones below it (tests/test_layers.py checks it):
  core   (cavesim.core)  no GL: scenes, CAVE geometry, frame inputs, records, scene
                         drivers, the clock, the wire, the float64 twin;
  gpu    (cavesim.gpu)   the OpenGL engine, its shaders, the wall renderer;
  nodes  (cavesim.nodes) the processes: master, wall node, launcher, harness;
  tools  (cavesim.tools) the command line, benchmarks, numerics, reports.
"""
