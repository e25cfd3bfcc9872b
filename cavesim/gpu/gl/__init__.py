"""OpenGL plumbing shared by the engine and, later, the renderer."""
