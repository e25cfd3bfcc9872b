"""The GPU layer: the OpenGL context, the shaders and their assembler, the particle engine
and the wall renderer. Built on `cavesim.core`."""
