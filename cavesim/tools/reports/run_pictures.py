"""A run's pictures after the fact: each saved frame's wall pictures joined into an
unfolded-CAVE composite, and the composites strung at the run's own pace into an MP4 and
a small GIF. `cavesim run` makes them after its run, `cavesim render` after re-running a
frame log; both read the walls' pictures from <folder>/walls/<wall>/frame_<k>.png."""

from __future__ import annotations

from pathlib import Path

from rich.progress import Progress

from cavesim.core.cave.geometry import Cave
from cavesim.core.output import check_written
from cavesim.gpu.render.animation import write_animation
from cavesim.gpu.render.composite import compose_run

GIF_WIDTH = 480  # px: the GIF is the small one; the MP4 keeps up to MAX_WIDTH_PX
ANIMATIONS = 2  # the MP4 and the GIF, each a step of the pictures' progress


def assemble_pictures(cave: Cave, folder: Path, seconds_each: float, progress: Progress,
                      name: str, video: bool = True) -> dict:
    """Composites of every frame that all walls of `cave` have in folder/walls, into
    folder/composites; with `video`, folder/<name>.mp4 and folder/<name>.gif, each composite
    held `seconds_each` (the time between two saved frames). What was written, for a
    report; a task of `progress` counts it."""
    steps = ANIMATIONS if video else 0
    task = progress.add_task("pictures", total=None, live="", unit="composites")
    composites = compose_run(cave, folder / "walls", folder / "composites",
                             lambda done, total: progress.update(task, completed=done,
                                                                 total=total + steps))
    images = {"walls": str(folder / "walls"), "composites": len(composites)}
    if not composites:
        return images
    images["last_composite"] = str(composites[-1])
    if video:
        pace = 1.0 / seconds_each  # composites per second
        images["video"] = str(write_animation(composites, folder / f"{name}.mp4", pace))
        progress.advance(task)
        images["animation"] = str(write_animation(composites, folder / f"{name}.gif", pace,
                                                  max_width=GIF_WIDTH))
        progress.advance(task)
        check_written(images["video"], images["animation"], *composites)
        progress.console.print(f"wrote {len(composites)} composites, {images['video']} and "
                               f"{images['animation']}")
    else:
        check_written(*composites)
        progress.console.print(f"wrote {len(composites)} composites in "
                               f"{folder / 'composites'}")
    return images
