"""The GPU layer: the OpenGL context, the shaders and their assembler, the particle engine
and the wall renderer. Built on `cavesim.core`.

`engine/programs.py` and `render/programs.py` are the same role in parallel folders: the
GL programs that folder builds, and the variants each is compiled in."""
