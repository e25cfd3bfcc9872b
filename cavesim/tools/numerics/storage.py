"""The float32 storage floor: the part of the float32 floor no integrator form removes.

The GPU keeps every particle's position and velocity in float32, so each step ends in a
rounding of the state to float32, whatever the arithmetic before it. While a particle's
velocity changes, the position's roundings (about ulp(|p|) / sqrt(12) per component and
step) random-walk to ~ ulp(|p|) sqrt(steps); once it moves at a steady velocity (terminal
velocity in a uniform flow, the settling speed along a vortex's axis) the increment h v is
the same every step, and so is its rounding against the float32 grid around p: that error
grows like steps, not their root. The storage floor is all of it: the RMS distance between
the float64 twin and the same twin whose state is rounded to float32 after every step. A
form is as good as float32 allows when its float32 floor (RMS |GPU - twin|) is at the
storage floor (docs/numerics.md: the float32 floor).

The position is stored as the particle record keeps it: float32 hi and a byte for what hi
leaves out (cavesim/core/position.py, 32 significant bits); `low_part=False` stores it as
one float32, as the record did before it had the low part.
"""

from __future__ import annotations

import numpy as np

from cavesim.core.features.feature import FrameState
from cavesim.core.position import extended_position, split_position
from cavesim.core.records import PARTICLE_DTYPE
from cavesim.core.scene.model import Integrator
from cavesim.core.twin.integrators import INTEGRATORS
from cavesim.core.twin.system import TwinSystem
from cavesim.tools.numerics.cases import Case


def storage_floors(case: Case, integrator: Integrator, dts: tuple[float, ...],
                   final_time: float, round_velocity: bool = True,
                   low_part: bool = True) -> list[float]:
    """m: per dt, RMS |float64 run - float64 run stored as the record keeps it every step| at
    final_time (its position, as a float32 alone unless `low_part`, and its velocity in
    float32 unless `round_velocity` is False)."""
    twin = TwinSystem(case.scene(integrator), np.float64)
    rotor = twin.rotor_inputs.read(case.frame) if twin.rotor_inputs is not None else None
    forces = twin.forces_for(case.particles["class_id"], FrameState(rotor=rotor))
    step = INTEGRATORS[integrator]
    floors = []
    for dt in dts:
        h = float(np.float32(dt))  # the engine's step, as the twin takes it
        exact_p = stored_p = case.particles["pos"].astype(np.float64)
        exact_v = stored_v = case.particles["vel"].astype(np.float64)
        for _ in range(round(final_time / dt)):
            exact_p, exact_v = step(exact_p, exact_v, h, forces)
            stored_p, stored_v = step(stored_p, stored_v, h, forces)
            stored_p = stored_position(stored_p, low_part)
            if round_velocity:
                stored_v = stored_v.astype(np.float32).astype(np.float64)
        floors.append(float(np.sqrt(np.mean(np.sum((exact_p - stored_p) ** 2, axis=1)))))
    return floors


def stored_position(position: np.ndarray, low_part: bool) -> np.ndarray:
    """The float64 position as the record keeps it: hi and its low part, or hi alone."""
    if not low_part:
        return position.astype(np.float32).astype(np.float64)
    records = np.zeros(len(position), PARTICLE_DTYPE)
    records["pos"], records["pos_low"] = split_position(position)
    return extended_position(records)
