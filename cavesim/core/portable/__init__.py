"""Portable arithmetic: the float32 numpy twin of the shaders' ARITHMETIC_PORTABLE mode,
whose results are the same bits on every GPU and here (`arithmetic`).

Modules named like others mirror them in portable arithmetic: `forces`, `integrators` and
`tracers` and `dispersion` (cavesim/core/twin/), `rotor` (cavesim/core/helicopter/)."""

from cavesim.core.portable.arithmetic import (
    f_add,
    f_cos,
    f_div,
    f_dot,
    f_exp,
    f_ftz,
    f_length,
    f_log,
    f_mix,
    f_mul,
    f_normalize,
    f_pow,
    f_sin,
    f_sqrt,
    f_sub,
)

__all__ = [
    "f_add", "f_cos", "f_div", "f_dot", "f_exp", "f_ftz", "f_length", "f_log", "f_mix",
    "f_mul", "f_normalize", "f_pow", "f_sin", "f_sqrt", "f_sub",
]
