"""A CAVE's walls as windows side by side on one desktop: where a wall's window opens when
its CAVE file says nothing, and small copies of the walls for trying live walls and
measuring the swap barrier on a machine without projectors (or under Xvfb)."""

from __future__ import annotations

from collections.abc import Sequence

from cavesim.core.cave.geometry import Cave

WINDOW_GAP = 8  # px between neighbouring windows


def desktop_cave_file(cave: Cave, walls: Sequence[str], width: int) -> str:
    """The text of a CAVE file holding `walls` of `cave`, each drawn `width` pixels wide (its
    height keeps the wall's aspect) in a window of that size, left to right along the top of
    the screen, without vsync, swap-locked."""
    lines = [f'name = "{cave.name}-desktop"', f"eye_separation = {cave.eye_separation!r}"]
    x = 0
    for name in walls:
        wall = cave.wall(name)
        height = max(1, round(width * wall.height / wall.width))
        lines += ["", "[[wall]]", f'name = "{name}"']
        lines += [f"{corner} = [{', '.join(repr(float(v)) for v in getattr(wall, corner))}]"
                  for corner in ("lower_left", "lower_right", "upper_left")]
        lines += [f"resolution = [{width}, {height}]",
                  f"display = {{ vsync = false, window = [{x}, 0, {width}, {height}] }}"]
        x += width + WINDOW_GAP
    return "\n".join(lines) + "\n"


def tiled_window(cave: Cave, walls: Sequence[str]) -> tuple[int, int, int, int]:
    """[x, y, width, height] of a window showing `walls` side by side at their resolution,
    placed after every wall the CAVE file lists before the first of them, left to right
    along the top of the screen with WINDOW_GAP between: where `cavesim run --display`
    opens a node's window when its wall's [wall.display] gives neither a window nor a
    monitor. Every node computes its own place from the CAVE alone."""
    names = [w.name for w in cave.walls]
    before = cave.walls[:names.index(walls[0])]
    x = sum(w.resolution[0] + WINDOW_GAP for w in before)
    shown = [cave.wall(name) for name in walls]
    return x, 0, sum(w.resolution[0] for w in shown), max(w.resolution[1] for w in shown)
