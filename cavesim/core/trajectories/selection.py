"""Which particles a run tracks: those whose birth index is a multiple of a stride S, below
N·S, with S = max(1, floor(B / N)) for B the births the scene's emitters nominally make over
the run (sum of their rates × frames × dt)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from cavesim.core.emitters import EmitterTable
from cavesim.core.scene.model import Scene

MAX_TRAJECTORIES = 1_000_000  # tracked particles a run may ask for


@dataclass(frozen=True)
class Selection:
    count: int  # N: at most this many particles are tracked
    stride: int  # S

    @classmethod
    def for_run(cls, scene: Scene, count: int, frames: int, dt: float) -> Selection:
        """N particles spread evenly over the births the scene nominally makes in the run."""
        if not 1 <= count <= MAX_TRAJECTORIES:
            raise ValueError(f"trajectories must be in [1, {MAX_TRAJECTORIES}], got {count!r}")
        births = float(EmitterTable.from_scene(scene).rate.astype(np.float64).sum()) \
            * frames * dt
        return cls(count, max(1, int(births // count)))

    def tracked(self, ids: np.ndarray) -> np.ndarray:
        """Mask of `ids` (birth indices) that are tracked."""
        stride = np.uint64(self.stride)
        return (ids % stride == 0) & (ids < stride * np.uint64(self.count))
