"""A scene's identity on the wire and in the frame log: a digest of what it holds.

Every host reads its own scene file, so the master and each node must show that they hold
the same scene before a frame is stepped. The digest is of the loaded `Scene`, not of the
file's bytes: the file's comments, layout, name and path do not change a single bit of the
simulation, and hosts keep the file wherever they like; but the .npz files a field or a
heightfield names do, so each is in by the SHA-256 of its bytes, not by its path. The
engine path is left out (both paths compute the same bits, and `--engine` overrides it).
It is SHA-256 over a canonical JSON of the rest (sorted keys, floats by their exact
`repr`, fields left unset out, and fields added with a default left out at it:
LATER_DEFAULTS), cut to 128 bits like every other digest on the wire.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
from enum import Enum
from pathlib import Path
from typing import Any

from cavesim.core.errors import SceneError
from cavesim.core.input_files import open_input
from cavesim.core.limits import MAX_FIELD_FILE_BYTES
from cavesim.core.scene.model import ParticleClass, Scene

NOT_CONTENT = ("name", "source", "engine")  # fields of a Scene that change no bit
def _defaults(cls: type, *names: str) -> dict[tuple[type, str], Any]:
    return {(cls, f.name): f.default for f in dataclasses.fields(cls) if f.name in names}


# Fields added with a default after frame logs were recorded: at that default a field is
# left out, so that the scenes that do not use it keep their digests and their logs replay
LATER_DEFAULTS = {**_defaults(ParticleClass, "motion"), **_defaults(Scene, "tracer_tolerance")}


def scene_digest(scene: Scene) -> str:
    """32 hex digits naming the scene's content (SceneError if a file it names is gone, or
    no regular file within MAX_FIELD_FILE_BYTES, the largest a scene's file may be)."""
    content = {name: value for name, value in _canonical(scene).items()
               if name not in NOT_CONTENT}
    text = json.dumps(content, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:32]


def _canonical(value: Any) -> Any:
    if dataclasses.is_dataclass(value):  # a field left unset (None) is left out: a new
        # optional key leaves every digest, and every recorded frame log, as it was
        return {f.name: _canonical(getattr(value, f.name)) for f in dataclasses.fields(value)
                if not _left_out(value, f.name)}
    if isinstance(value, Enum):
        return _canonical(value.value)
    if isinstance(value, Path):
        return {"sha256": _file_digest(value)}
    if isinstance(value, tuple | list):
        return [_canonical(item) for item in value]
    if isinstance(value, dict):
        return {str(key): _canonical(item) for key, item in value.items()}
    if isinstance(value, float):
        return repr(value)  # exact, and NaN or inf are not JSON
    return value


def _left_out(value: Any, name: str) -> bool:
    field = getattr(value, name)
    key = (type(value), name)
    return field is None or (key in LATER_DEFAULTS and field == LATER_DEFAULTS[key])


def _file_digest(path: Path) -> str:
    with open_input(path, SceneError, "a file the scene names", MAX_FIELD_FILE_BYTES) as file:
        try:
            return hashlib.file_digest(file, "sha256").hexdigest()
        except OSError as e:
            raise SceneError(f"{path}: cannot read it: {e.strerror or e}") from e
