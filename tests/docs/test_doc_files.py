"""The scene and CAVE files the docs show load as written: ```toml scene and ```toml cave
blocks go through the same loaders as files on disk."""

import re
import tomllib
from pathlib import Path

import pytest

from cavesim.core.cave.geometry import parse_cave
from cavesim.core.scene.loader import parse_scene

ROOT = Path(__file__).parents[2]
LOADERS = {"scene": parse_scene, "cave": parse_cave}
BLOCKS = [(f"{doc.relative_to(ROOT)}:{kind}", kind, body)
          for doc in [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]
          for kind, body in re.findall(r"^```toml (scene|cave)\n(.*?)^```", doc.read_text(),
                                       re.S | re.M)]


def test_the_guides_show_a_scene_and_a_cave():
    assert {kind for _, kind, _ in BLOCKS} == set(LOADERS)


@pytest.mark.parametrize("where,kind,body", BLOCKS, ids=[b[0] for b in BLOCKS])
def test_every_file_the_docs_show_loads(where, kind, body):
    LOADERS[kind](tomllib.loads(body))
