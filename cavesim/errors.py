"""The narrow exception classes cavesim raises at its input edges."""


class CavesimError(Exception):
    """Base of every error cavesim raises on purpose."""


class SceneError(CavesimError, ValueError):
    """A scene file or scene value is malformed: names file, key, value and what is allowed."""


class ShaderError(CavesimError):
    """GLSL source could not be assembled or compiled."""


class ContextError(CavesimError, RuntimeError):
    """No usable headless OpenGL context (names the package to install)."""


class FieldError(CavesimError, ValueError):
    """A vector field or height field is malformed (shape, dtype, non-finite values)."""
