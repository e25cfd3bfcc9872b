"""The docs' pictures, redrawn from the current code:
`python -m cavesim.tools.reports.doc_pictures [NAME ...]` (every one it can draw by default).

PICTURES is the table of every image under docs/images that README.md and docs/ show
(tests/docs/test_doc_pictures.py holds the docs to it): what each shows and what draws it
here, or the command that does where a picture is a measurement that takes far longer than
a drawing (a full accuracy run), or where it came from where it records code that is gone.
The wall pictures are the default CAVE unfolded, its walls at half their resolution, as
`cavesim run` and its preview draw them (the same renderer, driver, seed and head).
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from cavesim.core.cave import DEFAULT_CAVE
from cavesim.core.cave.geometry import load_cave
from cavesim.core.output import writing
from cavesim.core.scene import load_scene
from cavesim.gpu.gl.context import create_context
from cavesim.gpu.render.composite import compose
from cavesim.tools.reports.outwash_figure import plot_outwash
from cavesim.tools.reports.scene_pictures import draw_walls
from cavesim.tools.reports.technique_pictures import technique_pictures, technique_sheet

IMAGES = Path("docs/images")  # relative to the repository root
DOC_SCALE = 0.5  # the default CAVE's 480 px walls at 240 px: 720 x 480 composites


@dataclass(frozen=True)
class DocPicture:
    name: str  # the file under IMAGES
    shows: str
    draw: Callable[[Path], None] | None = None  # writes the picture to the path given
    command: str = ""  # what draws it, where `draw` does not


def unfolded(scene: str, frame: int) -> Callable[[Path], None]:
    """A drawing of the default CAVE's walls at `frame` of `scene`, unfolded."""
    def draw(path: Path) -> None:
        ctx = create_context()
        try:
            cave = load_cave(DEFAULT_CAVE).scaled(DOC_SCALE)
            walls = draw_walls(ctx, load_scene(scene), cave, {frame})[frame]
            with writing(path):
                compose(cave, walls.pictures).save(path, optimize=True)
        finally:
            ctx.release()
    return draw


def techniques(scene: str) -> Callable[[Path], None]:
    """The default CAVE's front wall without each drawing technique and with it."""
    def draw(path: Path) -> None:
        wall = load_cave(DEFAULT_CAVE).scaled(DOC_SCALE).wall("front")
        sheet = technique_sheet(technique_pictures(load_scene(scene), wall))
        with writing(path):
            sheet.save(path, optimize=True)
    return draw


ACCURACY = "drawn by `cavesim accuracy --out out/accuracy` (20,000 particles, about 40 min on " \
           "llvmpipe): copy out/accuracy/{name} here"
PICTURES = (
    DocPicture("brownout.png", "the brownout demo at frame 720",
               unfolded("config/scenes/brownout.toml", 720)),
    DocPicture("preview.png", "the preview window's picture at frame 750 of the brownout demo",
               unfolded("config/scenes/brownout.toml", 750)),
    DocPicture("cave_composite.png", "the dust devil after 300 frames",
               unfolded("config/scenes/dust_devil.toml", 300)),
    DocPicture("techniques.png", "each drawing technique left out and kept, in the brownout "
               "demo", techniques("config/scenes/brownout.toml")),
    DocPicture("outwash.png", "the downwash against the published wall-jet data", plot_outwash),
    DocPicture("work_precision.png", "error against GPU run time per integrator",
               command=ACCURACY.format(name="work_precision.png")),
    DocPicture("work_precision_evaluations.png", "error against field evaluations",
               command=ACCURACY.format(name="work_precision_evaluations.png")),
    DocPicture("brownout_before.png", "the brownout demo before its model changed",
               command="kept as drawn: a record of the model before commit ebbfad7, whose "
                       "code is gone"),
)


def main(names: list[str]) -> int:
    """Redraw the named pictures (default: every one with a drawing) under IMAGES."""
    table = {p.name: p for p in PICTURES}
    unknown = sorted(set(names) - set(table))
    if unknown:
        print(f"unknown pictures {unknown}; known: {', '.join(table)}", file=sys.stderr)
        return 2
    for picture in (table[n] for n in names or table):
        if picture.draw is None:
            print(f"{picture.name}: {picture.command}")
            continue
        picture.draw(IMAGES / picture.name)
        print(f"{picture.name}: {picture.shows}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
