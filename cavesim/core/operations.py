"""The float operations that code shared by the float64 twin and the portable twin takes as
an argument: numpy's in the array's own dtype (the reference), or the shaders' portable
ones, operation by operation in float32 (the GPU's bits)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from cavesim.core.portable.arithmetic import f_add, f_mul, f_sub


@dataclass(frozen=True)
class Operations:
    add: Callable
    sub: Callable
    mul: Callable


REFERENCE_OPERATIONS = Operations(np.add, np.subtract, np.multiply)
PORTABLE_OPERATIONS = Operations(f_add, f_sub, f_mul)
