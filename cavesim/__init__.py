"""cavesim: a GPU particle simulation kept bit-identical across the walls of a CAVE.

The engine library: scenes, fields, the GL particle system and its numpy twin, the wire.
The processes that use it live in the `nodes` package.
"""

from cavesim.engine import FrameInput, ParticleSystem, StateChecksum
from cavesim.gl.context import create_context
from cavesim.scene import Scene, load_scene

__all__ = ["FrameInput", "ParticleSystem", "Scene", "StateChecksum", "create_context",
           "load_scene"]
