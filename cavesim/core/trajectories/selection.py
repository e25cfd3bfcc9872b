"""Which particles a run tracks: those whose birth index is a multiple of a stride S, below
N·S, with S = max(1, floor(B / N)) for B the births the scene's emitters nominally make over
the run (the sum of their rates × the run's planned frames × its nominal dt)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from cavesim.core.emitters import EmitterTable
from cavesim.core.limits import MAX_TRAJECTORIES
from cavesim.core.scene.model import Scene


@dataclass(frozen=True)
class Selection:
    count: int  # N: at most this many particles are tracked
    stride: int  # S

    @classmethod
    def for_run(cls, scene: Scene, count: int, seconds: float) -> Selection:
        """N particles spread evenly over the births the scene nominally makes in a run of
        `seconds` (planned frames × nominal dt)."""
        if not 1 <= count <= MAX_TRAJECTORIES:
            raise ValueError(f"trajectories must be in [1, {MAX_TRAJECTORIES}], got {count!r}")
        births = float(EmitterTable.from_scene(scene).rate.astype(np.float64).sum()) * seconds
        return cls(count, max(1, int(births // count)))

    def tracked(self, ids: np.ndarray) -> np.ndarray:
        """Mask of `ids` (birth indices) that are tracked."""
        stride = np.uint64(self.stride)
        return (ids % stride == 0) & (ids < stride * np.uint64(self.count))
