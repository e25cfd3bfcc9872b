"""Uniform values of the engine's programs: each feature's, as the exact float32 and uint32
bits it gives them (`cavesim.core.features`), written by name."""

from __future__ import annotations

from collections.abc import Mapping

import moderngl
import numpy as np

from cavesim.core.errors import ShaderError


def write_uniforms(program: moderngl.Program, values: Mapping[str, object]) -> None:
    """Write each value's exact bytes to the uniform of that name in the program.

    A uniform its source declares but the compiler dropped (unused in this combination of
    features) is skipped; a name its source never declares is a ShaderError (a typo, or
    host and shader out of step). dtype decides the bits: float32 and uint32 go up as is.
    """
    unknown = sorted(set(values) - program.extra["declared"])
    if unknown:
        raise ShaderError(f"{program.extra['name']} declares no uniform {', '.join(unknown)}; "
                          f"it declares {', '.join(sorted(program.extra['declared']))}")
    for name, value in values.items():
        if (uniform := program.get(name, None)) is not None:
            uniform.write(np.ascontiguousarray(value).tobytes())
