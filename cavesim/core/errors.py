"""The narrow exception classes cavesim raises at its input edges."""


class CavesimError(Exception):
    """Base of every error cavesim raises on purpose."""


class SceneError(CavesimError, ValueError):
    """A scene file or scene value is malformed: names file, key, value and what is allowed."""


class ModelError(CavesimError, ValueError):
    """A helicopter model file (glTF) cannot be drawn: names the file, what is wrong in it
    and what is allowed."""


class CaveError(CavesimError, ValueError):
    """A CAVE geometry file is malformed: names file, wall key, value and what is allowed."""


class ShaderError(CavesimError):
    """GLSL source could not be assembled or compiled."""


class ContextError(CavesimError, RuntimeError):
    """No usable headless OpenGL context or EGL device: `problem` says what is wrong, `fix`
    what to do (the packages to install, the flag to change); the message is both."""

    def __init__(self, problem: str, fix: str) -> None:
        super().__init__(f"{problem}; {fix}")
        self.problem = problem
        self.fix = fix


class CapacityError(CavesimError, ValueError):
    """A capacity the GL context cannot hold: names the capacity, the bytes it needs, the
    limit that binds (by its GL name and value), the largest capacity allowed and the driver."""


class StateError(CavesimError, ValueError):
    """A particle or emitter state was refused: records of the wrong shape or count, or a
    staged load whose checksum is not the announced one (the current state is kept)."""


class FieldError(CavesimError, ValueError):
    """A vector field or height field is malformed (shape, dtype, non-finite values)."""


class ProtocolError(CavesimError, ValueError):
    """A wire message, or a tracking system's datagram, was rejected; `reason` is a short
    stable name for counting."""

    def __init__(self, reason: str, detail: str) -> None:
        super().__init__(f"{reason}: {detail}")
        self.reason = reason


class TrackerError(CavesimError, ValueError):
    """A tracker bridge cannot start: its mapping file is malformed (names file, key, value
    and what is allowed) or its UDP port cannot be opened (names the address)."""


class TrajectoryError(CavesimError, RuntimeError):
    """The trajectory recorder lost the particle stream's identity (its prediction of the
    survivors and the engine's count disagree in a way no runaway drop explains)."""


class ClusterError(CavesimError, RuntimeError):
    """A cluster process failed, or the cluster cannot go on: names the process, its own
    error line and its log."""


class OutputError(CavesimError):
    """A result file could not be written (a full disk, a read-only or deleted folder):
    names the file and the reason."""
