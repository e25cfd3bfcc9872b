"""The numpy twin of the GPU engine: the same forces, integrators, collisions and emission.

In float64 it is the reference the GPU is tested against; in float32 it is the CPU
baseline of the benchmark; for a scene in portable arithmetic it computes with the
portable kernels (`kernels.py`, cavesim/core/portable/) and holds the GPU's bits
(`system.py`: `TwinSystem`). Each function names the shader lines it mirrors; `emission`
mirrors cavesim/gpu/engine/emission.py. The kernels here take plain values, never a scene's
tables, so a feature (cavesim/core/features/) may name them without a cycle.
"""
