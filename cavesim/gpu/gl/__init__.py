"""OpenGL plumbing: the context, the EGL devices and what the driver offers (its filter
precision, its limits), shared by the engine, the renderer and `cavesim doctor`."""
