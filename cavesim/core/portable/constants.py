"""The shaders' float constants that no short literal spells exactly, as float32 bits.

A GLSL compiler may round a literal such as 0.3 or 1.0 / 6.0 its own way, so the shaders
write these as `#define NAME uintBitsToFloat(0x...u)`; here are the same bits under the
same names (tests/gpu/test_portable_physics.py holds the two sides together).
"""

from __future__ import annotations

import numpy as np


def _bits(word: int) -> np.float32:
    return np.array(word, dtype=np.uint32).view(np.float32)[()]


# integrators.glsl: 1/k! of the exponential integrators' series
INV_FACTORIAL_3 = _bits(0x3E2AAAAB)
INV_FACTORIAL_4 = _bits(0x3D2AAAAB)
INV_FACTORIAL_5 = _bits(0x3C088889)
INV_FACTORIAL_6 = _bits(0x3AB60B61)
INV_FACTORIAL_7 = _bits(0x39500D01)
INV_FACTORIAL_8 = _bits(0x37D00D01)
INV_FACTORIAL_9 = _bits(0x3638EF1D)  # ETD2RK's phi3
INV_FACTORIAL_10 = _bits(0x3493F27E)
INV_FACTORIAL_11 = _bits(0x32D7322B)

# rotor.glsl: the downwash model's constants (their float64 values: cavesim/core/helicopter/
# downwash.py)
WAKE_SPREADING = _bits(0x3E0D4FDF)  # 0.138
WALL_JET_GROWTH = _bits(0x3F0D4371)  # 2 sqrt(2 pi) 0.098 1.03 F
WALL_JET_WIDTH_SQ = _bits(0x3C1D5A18)  # 0.098²
FOUR_PROFILE_INTEGRAL = _bits(0x408B93F0)  # 4 F
PROFILE_DECAY = _bits(0x40066666)  # 2.1
PROFILE_SHAPE = _bits(0x40533333)  # 3.3
PROFILE_INNER = _bits(0x4274CCCD)  # 61.2
PROFILE_FLUX = _bits(0x3F986CE4)  # the profile's integral
ONE_FIFTH = _bits(0x3E4CCCCD)  # 0.2
TWO_FIFTHS = _bits(0x3ECCCCCD)  # 0.4
WIDTH_POWER = _bits(0x3FE66666)  # 1.8
HALF_WIDTH_POWER = _bits(0x3EE66666)  # 0.45

# spawn.glsl
TWO_PI = _bits(0x40C90FDB)

# forces.glsl: Schiller-Naumann's drag (cavesim/core/drag.py)
SCHILLER_NAUMANN_COEFFICIENT = _bits(0x3E19999A)  # 0.15
SCHILLER_NAUMANN_EXPONENT = _bits(0x3F2FDF3B)  # 0.687

# dispersion.glsl (cavesim/core/twin/dispersion.py)
KARMAN = _bits(0x3ECCCCCD)  # 0.4
SHEAR_STEP = _bits(0x3DCCCCCD)  # 0.1
HALF_SHEAR_STEP = _bits(0x3D4CCCCD)  # 0.05
SQRT_3 = _bits(0x3FDDB3D7)
TURBULENCE_FLOOR = _bits(0x3DCCCCCD)  # 0.1
