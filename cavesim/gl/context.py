"""The headless OpenGL context every wall node (and every test) computes in.

A surfaceless EGL context has no default framebuffer, and Mesa refuses transform-feedback
draws without one (GL_INVALID_FRAMEBUFFER_OPERATION, nothing written), so the context is
handed out with a 1x1 framebuffer bound.

One context per process: creating a context makes it current, and moderngl does not
switch back, so a second context in the same process takes over the first one's calls.
That is the CAVE's own shape anyway: one wall node process, one context.
"""

from __future__ import annotations

import moderngl

from cavesim.errors import ContextError

REQUIRED_GL_VERSION = 430  # compute shaders, SSBOs (GS + TF need 3.3); every program's #version

_PACKAGE_HINT = (
    "install the Debian packages libegl1 and libgl1-mesa-dri "
    "(`apt-get install libegl1 libgl1-mesa-dri`, or run deploy/setup.sh)"
)


def create_context(require: int = REQUIRED_GL_VERSION) -> moderngl.Context:
    """Open a standalone EGL context of GL `require` or newer with a tiny framebuffer bound."""
    try:
        ctx = moderngl.create_standalone_context(backend="egl", require=require)
    except Exception as e:  # moderngl/glcontext raise plain Exception for a missing library
        raise ContextError(f"cannot open a headless OpenGL context through EGL: {e}; "
                           f"{_PACKAGE_HINT}") from e
    if ctx.version_code < require:
        found = ctx.info.get("GL_VERSION")
        ctx.release()
        raise ContextError(f"OpenGL {require // 100}.{require % 100 // 10} core is required, "
                           f"the driver offers {found!r}; {_PACKAGE_HINT} for Mesa's llvmpipe")
    framebuffer = ctx.simple_framebuffer((1, 1))
    framebuffer.use()
    ctx.extra = {"framebuffer": framebuffer}
    return ctx


def describe(ctx: moderngl.Context) -> dict[str, str]:
    """Renderer, vendor and version strings, for reports."""
    keys = ("renderer", "vendor", "version")
    return {key: str(ctx.info.get(f"GL_{key.upper()}")) for key in keys}
