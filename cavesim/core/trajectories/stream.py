"""What the trajectory recorder reads of an engine after a step, and the float64 twin's
side of it (the GL engine's is `cavesim.gpu.engine.trajectory_stream`)."""

from __future__ import annotations

from typing import Protocol

import numpy as np

from cavesim.core.twin.system import TwinSystem


class ParticleStream(Protocol):
    @property
    def live_count(self) -> int: ...

    def survivors(self) -> int:
        """Particles of the stream before the last step that are still in it."""

    def records(self, first: int, count: int) -> np.ndarray:
        """Records [first, first + count) of the live stream (PARTICLE_DTYPE)."""

    def picked(self, indices: np.ndarray) -> np.ndarray:
        """Records at the ascending stream `indices` (PARTICLE_DTYPE)."""


def survivors_of(live: int, dropped: int, emitters: np.ndarray) -> int:
    """Particles of the stream before a step still in it after: live = survivors + emitted -
    dropped (cavesim/gpu/engine/drops.py), from the emitter stream's counts (EMITTER_DTYPE)."""
    return live + dropped - int(emitters["count"].sum())


class TwinStream:
    """A `TwinSystem` as a ParticleStream (its records as the GPU would hold them)."""

    def __init__(self, twin: TwinSystem) -> None:
        self.twin = twin

    @property
    def live_count(self) -> int:
        return self.twin.live_count

    def survivors(self) -> int:
        return survivors_of(self.twin.live_count, self.twin.dropped(), self.twin.emitters)

    def records(self, first: int, count: int) -> np.ndarray:
        return self.twin.particles.select(slice(first, first + count)).records()

    def picked(self, indices: np.ndarray) -> np.ndarray:
        return self.twin.particles.select(np.asarray(indices, np.int64)).records()
