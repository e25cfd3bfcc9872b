"""Every TOML input (a scene, a CAVE, a tracker mapping, a key file) refuses a file nested
deeper than the readers allow with one line, never a RecursionError."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import pytest

from cavesim.core._toml import MAX_NESTING
from cavesim.core.cave.geometry import load_cave
from cavesim.core.errors import CaveError, SceneError, TrackerError
from cavesim.core.scene import load_scene
from cavesim.core.tracking.mapping import load_mapping
from cavesim.core.wire.key_files import read_key_file

READERS: dict[str, tuple[Callable[[Path], object], type[Exception]]] = {
    "scene": (load_scene, SceneError),
    "cave": (load_cave, CaveError),
    "mapping": (load_mapping, TrackerError),
}
DEEP = {
    "arrays past the parser's recursion": "a = " + "[" * 5000 + "]" * 5000 + "\n",
    "inline tables past the parser's recursion": "a = " + "{b = " * 5000 + "1" + "}" * 5000,
    "arrays just past the limit": "a = " + "[" * (MAX_NESTING + 1) + "]" * (MAX_NESTING + 1),
    "a dotted table header": "[" + ".".join(["t"] * 1000) + "]\nx = 1\n",
    "a dotted key": ".".join(["k"] * 1000) + " = 1\n",
}


@pytest.mark.parametrize("reader", READERS)
@pytest.mark.parametrize("text", DEEP.values(), ids=DEEP)
def test_deep_nesting_is_one_line(tmp_path: Path, reader: str, text: str) -> None:
    load, error = READERS[reader]
    path = tmp_path / "deep.toml"
    path.write_text(text)
    with pytest.raises(error) as raised:
        load(path)
    line = str(raised.value)
    assert "\n" not in line and str(path) in line
    assert f"nested deeper than {MAX_NESTING} levels" in line


def test_nesting_at_the_limit_reaches_the_schema(tmp_path: Path) -> None:
    path = tmp_path / "scene.toml"
    path.write_text("a = " + "[" * MAX_NESTING + "]" * MAX_NESTING + "\n")
    with pytest.raises(SceneError) as raised:
        load_scene(path)
    assert "nested" not in str(raised.value)


def test_deep_key_file_is_not_a_key_file(tmp_path: Path) -> None:
    path = tmp_path / "wall-front.key"
    path.write_text("a = " + "[" * 5000 + "]" * 5000 + "\n")
    path.chmod(0o600)
    with pytest.raises(ValueError, match="not a cavesim key file"):
        read_key_file(path, "wall", "front")
