"""The arithmetic a `TwinSystem` computes with: the reference's or the portable one's.

REFERENCE kernels are the twin's own (float64: the accuracy reference; float32: the CPU
baseline of the benchmark). PORTABLE kernels (cavesim/core/portable/) repeat the shaders'
portable arithmetic operation by operation in float32: bit for bit the GPU's state.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from functools import partial

import numpy as np

from cavesim.core.operations import PORTABLE_OPERATIONS, REFERENCE_OPERATIONS, Operations
from cavesim.core.portable import spawn as portable_spawn
from cavesim.core.portable.forces import PortableForces
from cavesim.core.portable.integrators import INTEGRATORS as PORTABLE_INTEGRATORS
from cavesim.core.portable.tracers import TRACERS as PORTABLE_TRACERS
from cavesim.core.scene.model import Integrator, TracerMethod
from cavesim.core.twin import emission
from cavesim.core.twin.forces import ForceModel
from cavesim.core.twin.integrators import INTEGRATORS
from cavesim.core.twin.tracers import TRACERS


@dataclass(frozen=True)
class Kernels:
    """The arithmetic of the motion itself; a feature's own kernels are its module's, which
    picks the portable ones by `portable` (cavesim.core.features)."""

    dtype: type  # of positions and velocities
    portable: bool  # the portable arithmetic's kernels, the GPU's bits
    integrators: Mapping[Integrator, Callable]  # (p, v, h, forces) -> (p, v)
    tracers: Mapping[TracerMethod, Callable]  # (p, h, forces) -> (p, v) of a passive tracer
    # (gravity, damping, inv_tau, flow, reynolds_per_speed, turbulence) -> a model with
    # acceleration(p, v), linear_parts(p, v), forcing(p, drag) and drag_rate(slip)
    forces: Callable
    spawn: Callable  # (table, e, serials, random, transform, origin) -> records
    operations: Operations  # add, sub, mul as the kernels compute them


def reference_kernels(dtype) -> Kernels:
    """The twin's own arithmetic in `dtype`."""
    return Kernels(dtype, False, INTEGRATORS, TRACERS, ForceModel,
                   partial(emission.spawn, dtype=dtype), REFERENCE_OPERATIONS)


PORTABLE = Kernels(np.float32, True, PORTABLE_INTEGRATORS, PORTABLE_TRACERS, PortableForces,
                   portable_spawn.spawn, PORTABLE_OPERATIONS)
