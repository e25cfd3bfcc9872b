"""The inputs of one frame, exactly as the clock owner sends them to every node."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from cavesim.core.random_texture import validate_transform


@dataclass(frozen=True)
class FrameInput:
    dt: float  # seconds; rounded to float32 on entry, the bits every node uses
    random_transform: np.ndarray  # (3, 3) float32 integer affine map of the random texture

    def __post_init__(self) -> None:
        dt = np.float32(self.dt)
        if not math.isfinite(dt) or dt < 0:
            raise ValueError(f"dt must be finite and >= 0, got dt={self.dt!r}")
        object.__setattr__(self, "dt", dt)
        object.__setattr__(self, "random_transform", validate_transform(self.random_transform))
