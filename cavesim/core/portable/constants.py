"""The shaders' float constants that no short literal spells exactly, as float32 bits.

A GLSL compiler may round a literal such as 0.3 or 1.0 / 6.0 its own way, so the shaders
write these as `#define NAME uintBitsToFloat(0x...u)`; here are the same bits under the
same names (tests/test_portable_physics.py holds the two sides together).
"""

from __future__ import annotations

import numpy as np


def _bits(word: int) -> np.float32:
    return np.array(word, dtype=np.uint32).view(np.float32)[()]


# physics.glsl: 1/k! of the exponential integrators' series
INV_FACTORIAL_3 = _bits(0x3E2AAAAB)
INV_FACTORIAL_4 = _bits(0x3D2AAAAB)
INV_FACTORIAL_5 = _bits(0x3C088889)
INV_FACTORIAL_6 = _bits(0x3AB60B61)
INV_FACTORIAL_7 = _bits(0x39500D01)
INV_FACTORIAL_8 = _bits(0x37D00D01)
INV_FACTORIAL_9 = _bits(0x3638EF1D)  # ETD2RK's phi3
INV_FACTORIAL_10 = _bits(0x3493F27E)
INV_FACTORIAL_11 = _bits(0x32D7322B)

# rotor.glsl: the downwash model's shape constants (cavesim/core/helicopter/rotor.py)
WAKE_FLOOR = _bits(0x3A83126F)  # 1e-3
TURN_HEIGHT = _bits(0x3E99999A)  # 0.3
JET_THICKNESS = _bits(0x3DCCCCCD)  # 0.1
JET_GROWTH = _bits(0x3D4CCCCD)  # 0.05
JET_DECAY = _bits(0x3F8CCCCD)  # 1.1
UPWASH_HEIGHT = _bits(0x3F4CCCCD)  # 0.8

# spawn.glsl
TWO_PI = _bits(0x40C90FDB)

# physics.glsl: Schiller-Naumann's drag (cavesim/core/drag.py)
SCHILLER_NAUMANN_COEFFICIENT = _bits(0x3E19999A)  # 0.15
SCHILLER_NAUMANN_EXPONENT = _bits(0x3F2FDF3B)  # 0.687

# dispersion.glsl (cavesim/core/dispersion.py)
KARMAN = _bits(0x3ECCCCCD)  # 0.4
SHEAR_STEP = _bits(0x3DCCCCCD)  # 0.1
HALF_SHEAR_STEP = _bits(0x3D4CCCCD)  # 0.05
SQRT_3 = _bits(0x3FDDB3D7)
