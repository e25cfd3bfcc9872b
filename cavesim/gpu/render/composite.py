"""The unfolded CAVE: every wall's picture laid out flat in one image, shared edges joined.

The last step of a run's data flow: the wall nodes write `<wall>/frame_<NNNNNN>.png`,
`compose_run` joins each frame's wall pictures into `composite_<NNNNNN>.png`, and
`cavesim.gpu.render.animation` strings those into an animation. A wall picture's row 0 is the
wall's upper edge and column 0 its left edge, as seen from inside the room.
"""

from __future__ import annotations

import logging
import re
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from PIL import Image

from cavesim.core.output import writing
from cavesim.gpu.render.unfold import Slot, slots_of

if TYPE_CHECKING:
    from cavesim.core.cave.geometry import Cave

log = logging.getLogger(__name__)

FRAME_RE = re.compile(r"frame_(\d+)\.png")
DEFAULT_BACKGROUND = (24, 24, 28)
_TRANSPOSE = {1: Image.Transpose.ROTATE_90, 2: Image.Transpose.ROTATE_180,
              3: Image.Transpose.ROTATE_270}


def _rgb(name: str, image: Image.Image | np.ndarray) -> Image.Image:
    if isinstance(image, Image.Image):
        return image.convert("RGB")
    a = np.asarray(image)
    if a.ndim not in (2, 3) or (a.ndim == 3 and a.shape[2] not in (3, 4)):
        raise ValueError(f"image of wall {name!r} must be (height, width), (height, width, 3) "
                         f"or (height, width, 4), got shape {a.shape}")
    if np.issubdtype(a.dtype, np.floating):
        a = np.rint(np.clip(a, 0.0, 1.0) * 255.0)
    elif a.dtype != np.uint8:
        raise ValueError(f"image of wall {name!r} must be uint8 or float in [0, 1], "
                         f"got dtype {a.dtype}")
    if a.ndim == 2:
        a = np.repeat(a[:, :, None], 3, axis=2)
    return Image.fromarray(np.ascontiguousarray(a[:, :, :3], dtype=np.uint8), "RGB")


def _compose(slots: dict[str, Slot], size: tuple[int, int],
             images: Mapping[str, Image.Image | np.ndarray],
             background: tuple[int, int, int]) -> Image.Image:
    canvas = Image.new("RGB", size, tuple(background))
    for name, image in images.items():
        slot = slots[name]
        picture = _rgb(name, image)
        if picture.size != slot.size:
            picture = picture.resize(slot.size, Image.Resampling.LANCZOS)
        if slot.turns:
            picture = picture.transpose(_TRANSPOSE[slot.turns])
        canvas.paste(picture, (slot.x, slot.y))
    return canvas


def compose(cave: Cave, images: Mapping[str, Image.Image | np.ndarray],
            background: tuple[int, int, int] = DEFAULT_BACKGROUND) -> Image.Image:
    """The unfolded-CAVE composite (RGB) of one frame's wall pictures, laid out as
    `unfold_layout` says; a picture of another size than its slot is resized to fit,
    and walls without a picture leave `background`."""
    slots, size = slots_of(cave)
    unknown = sorted(set(images) - set(slots))
    if unknown:
        raise ValueError(f"images for unknown walls {unknown}; cave {cave.name!r} has walls "
                         f"{list(slots)}")
    return _compose(slots, size, images, background)


def _frame_files(wall_dir: Path) -> dict[int, Path]:
    if not wall_dir.is_dir():
        return {}
    return {int(m.group(1)): p for p in wall_dir.iterdir() if (m := FRAME_RE.fullmatch(p.name))}


def _brief(numbers: list[int], limit: int = 10) -> str:
    shown = ", ".join(map(str, numbers[:limit]))
    return shown + (f", ... ({len(numbers)} in all)" if len(numbers) > limit else "")


def compose_run(cave: Cave, walls_dir: Path, out_dir: Path,
                progress: Callable[[int, int], None] = lambda done, total: None) -> list[Path]:
    """Write `out_dir/composite_<NNNNNN>.png` for every frame number that every wall has
    in `walls_dir/<wall>/frame_<NNNNNN>.png`; the paths written, in frame order. Frames
    some wall lacks are skipped with a warning naming them. `progress(done, total)` after
    each."""
    walls_dir, out_dir = Path(walls_dir), Path(out_dir)
    if not walls_dir.is_dir():
        raise FileNotFoundError(f"walls_dir={str(walls_dir)!r} is not a directory")
    slots, size = slots_of(cave)
    files = {w.name: _frame_files(walls_dir / w.name) for w in cave.walls}
    every = set.intersection(*(set(f) for f in files.values()))
    some = set.union(*(set(f) for f in files.values()))
    if some - every:
        lacking = "; ".join(f"{name} lacks {_brief(sorted(some - set(f)))}"
                            for name, f in files.items() if some - set(f))
        log.warning("skipping %d frame(s) not written by every wall of cave %r: %s",
                    len(some - every), cave.name, lacking)
    out_dir.mkdir(parents=True, exist_ok=True)
    written = []
    for n in sorted(every):
        images = {}
        for name, f in files.items():
            with Image.open(f[n]) as im:
                images[name] = im.convert("RGB")
        path = out_dir / f"composite_{n:06d}.png"
        with writing(path):
            _compose(slots, size, images, DEFAULT_BACKGROUND).save(path)
        written.append(path)
        progress(len(written), len(every))
    return written
