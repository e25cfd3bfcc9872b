"""The case every tool runs in benchmarks/parcels_vortex.py: passive tracers in the
solid-body vortex (1 rad/s) on a 64³ float32 grid, interpolated trilinearly, stepped with RK4
for 60 steps of 1/60 s from the same disk of radius 0.8 m, and measured against the rotation
in closed form."""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass

import numpy as np

from cavesim.tools.numerics.solid_body import disk, rotated

NODES = 64  # per axis, spanning solid_body.BOX
DT = 1 / 60  # s
STEPS = 60
RADIUS = 0.8  # m: the disk the particles start in, at height 0.5 m


@dataclass(frozen=True)
class Run:
    """One tool's run at one size: its time per step and its error after STEPS steps."""

    tool: str
    particles: int
    step_s: float  # median over the steps, each timed alone
    total_s: float  # all steps
    rms_m: float  # over the particles, of the distance to the closed form
    max_m: float

    @property
    def rate(self) -> float:
        """Particles stepped per second."""
        return self.particles / self.step_s

    def to_json(self) -> dict:
        return asdict(self) | {"particles_per_s": self.rate}


def start_positions(count: int) -> np.ndarray:
    """(count, 3) float64 holding float32 values: every tool starts from these exact points
    (cavesim's record holds float32, Parcels' default particles too)."""
    return disk(count, radius=RADIUS).astype(np.float32).astype(np.float64)


def position_errors(start: np.ndarray, end: np.ndarray, elapsed: float) -> tuple[float, float]:
    """(RMS, max) over the particles of |end - start rotated by Omega * elapsed|, metres."""
    distance = np.linalg.norm(end - rotated(start, elapsed), axis=1)
    return float(np.sqrt(np.mean(distance**2))), float(distance.max())


def time_steps(step: Callable[[], object]) -> tuple[float, float]:
    """Call `step` STEPS times, each timed alone (it must end with its work done):
    (median, total) seconds."""
    times = []
    for _ in range(STEPS):
        start = time.perf_counter()
        step()
        times.append(time.perf_counter() - start)
    return statistics.median(times), sum(times)
