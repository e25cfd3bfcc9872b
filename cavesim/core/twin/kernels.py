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

from cavesim.core.fields.grid import FieldSeries, outside_box, sample_field
from cavesim.core.fields.regular_grid import mix
from cavesim.core.fields.snapshot_time import FieldTime, places_in_step
from cavesim.core.helicopter.downwash import downwash
from cavesim.core.operations import PORTABLE_OPERATIONS, REFERENCE_OPERATIONS, Operations
from cavesim.core.portable import dispersion as portable_dispersion
from cavesim.core.portable import field as portable_field
from cavesim.core.portable import ground as portable_ground
from cavesim.core.portable import rotor as portable_rotor
from cavesim.core.portable import spawn as portable_spawn
from cavesim.core.portable.arithmetic import f_mix
from cavesim.core.portable.forces import PortableForces
from cavesim.core.portable.integrators import INTEGRATORS as PORTABLE_INTEGRATORS
from cavesim.core.portable.tracers import TRACERS as PORTABLE_TRACERS
from cavesim.core.scene.model import Integrator, TracerMethod
from cavesim.core.twin import collision, dispersion, emission
from cavesim.core.twin.forces import ForceModel
from cavesim.core.twin.integrators import INTEGRATORS
from cavesim.core.twin.tracers import TRACERS


@dataclass(frozen=True)
class Kernels:
    dtype: type  # of positions and velocities
    integrators: Mapping[Integrator, Callable]  # (p, v, h, forces) -> (p, v)
    tracers: Mapping[TracerMethod, Callable]  # (p, h, forces) -> (p, v) of a passive tracer
    # (gravity, damping, inv_tau, flow, reynolds_per_speed, turbulence) -> a model with
    # acceleration(p, v), linear_parts(p, v), forcing(p, drag) and drag_rate(slip)
    forces: Callable
    rotor_flow: Callable  # (p, hub, v_i, rotor_radius, ground_z) -> u(p)
    field_flow: Callable  # (grid, p, out_of_domain) -> u(p)
    mix: Callable  # (a, b, t) -> GLSL's mix: the shader's f_mix in either arithmetic
    outside_field: Callable  # (grid, p) -> (N,) whether each point is outside the box
    ground: Callable  # (collision, heights, xy) -> (height, normal)
    collide: Callable  # (p, v, collision, heights) -> (p, v)
    turbulence: Callable  # (forces, p, v, ground, mixing_length, xi, h) -> u_t
    spawn: Callable  # (table, e, serials, random, transform, origin) -> records
    operations: Operations  # add, sub, mul as the kernels compute them

    def series_flow(self, series: FieldSeries, p: np.ndarray, out_of_domain,
                    field_time: FieldTime, stage: int | np.ndarray | None) -> np.ndarray:
        """u(p) at a stage of the step, or at each point's fraction of it: flow_at and
        flow_in_step of shaders/include/field.glsl (a steady field's one snapshot, else the
        pair there mixed by its weight)."""
        if series.steady:
            return self.field_flow(series.first, p, out_of_domain)
        if stage is None:
            raise ValueError("a time series' flow is known at a step's start, middle and end")
        if isinstance(stage, np.ndarray):  # each point's fraction of the step
            pairs, weights = places_in_step(field_time, stage, len(series.snapshots),
                                            self.operations)
        else:
            pairs = np.full(len(p), field_time.pairs[stage])
            weights = np.full(len(p), field_time.weights[stage], dtype=self.dtype)
        flow = np.empty_like(p)
        for pair in np.unique(pairs):
            rows = pairs == pair
            first, second = series.snapshots[pair], series.snapshots[pair + 1]
            flow[rows] = self.mix(self.field_flow(first, p[rows], out_of_domain),
                                  self.field_flow(second, p[rows], out_of_domain),
                                  weights[rows][:, None])
        return flow


def reference_kernels(dtype) -> Kernels:
    """The twin's own arithmetic in `dtype`."""
    return Kernels(dtype, INTEGRATORS, TRACERS, ForceModel, partial(downwash, dtype=dtype),
                   partial(sample_field, dtype=dtype), mix, partial(outside_box, dtype=dtype),
                   partial(collision.ground, dtype=dtype),
                   collision.collide, dispersion.turbulence, partial(emission.spawn, dtype=dtype),
                   REFERENCE_OPERATIONS)


PORTABLE = Kernels(np.float32, PORTABLE_INTEGRATORS, PORTABLE_TRACERS, PortableForces,
                   portable_rotor.flow_at, portable_field.flow_at, f_mix,
                   portable_field.outside_field, portable_ground.ground_at, portable_ground.collide,
                   portable_dispersion.turbulence, portable_spawn.spawn, PORTABLE_OPERATIONS)
