"""The numpy twin of the GPU engine: the same forces, integrators, collisions and emission.

In float64 it is the reference the GPU is tested against; in float32 it is the CPU
baseline of the benchmark; for a scene in portable arithmetic it computes with the
portable kernels (`kernels.py`, cavesim/core/portable/) and holds the GPU's bits. Each
function names the shader lines it mirrors; `emission` mirrors cavesim/gpu/engine/emission.py.
"""

from cavesim.core.twin.integrators import INTEGRATORS
from cavesim.core.twin.system import TwinSystem

__all__ = ["INTEGRATORS", "TwinSystem"]
