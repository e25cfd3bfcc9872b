"""What one benchmark size measured (median seconds per path) and the targets it is held to.

`TARGETS` is the one table the report and the tests both read, so they cannot drift apart.
The numpy twin is timed only up to a size cap: above it its seconds, rate and ratio are None.
"""

from __future__ import annotations

import operator
from dataclasses import dataclass

ENGINES = ("gs_tf", "compute")
# Timed paths, as keys of `seconds`: a whole frame and the particle pass alone per engine
# path, the checksum, the copy bound and the numpy twin
PATHS = ("gs_tf_frame", "compute_frame", "gs_tf_portable_frame", "compute_portable_frame",
         "gs_tf_update", "compute_update", "checksum", "copy", "numpy")
RATIOS = ("compute_speedup", "gs_tf_frame_vs_copy", "compute_frame_vs_copy",
          "gs_tf_update_vs_copy", "compute_update_vs_copy", "gs_tf_vs_numpy",
          "checksum_share", "gs_tf_portable_cost", "compute_portable_cost")


@dataclass(frozen=True)
class SizeFigures:
    particles: int
    gs_tf_frame_s: float  # ParticleSystem.step + checksum on the GS/TF path
    compute_frame_s: float  # the same on the compute path (its one wait is in the checksum)
    gs_tf_portable_frame_s: float  # the GS/TF frame with [simulation] arithmetic = "portable"
    compute_portable_frame_s: float  # the compute frame likewise
    gs_tf_update_s: float  # the GS/TF particle pass alone (transform feedback)
    compute_update_s: float  # the compute particle pass alone (in place, survivor masks)
    checksum_s: float  # one ParticleSystem.checksum()
    copy_s: float  # ctx.copy_buffer of the live particle state: the memory-bandwidth bound
    numpy_s: float | None  # one TwinSystem(float32).step; None: not timed at this size
    frames: dict[str, int]  # timed frames per path (after the warm-up), 0 where not timed
    live_after: int  # live particles after the timed frames: all of them, nothing dies

    @property
    def compute_speedup(self) -> float:
        """How many times faster the compute path's whole frame is than GS/TF's."""
        return self.gs_tf_frame_s / self.compute_frame_s

    @property
    def gs_tf_frame_vs_copy(self) -> float:
        return self.gs_tf_frame_s / self.copy_s

    @property
    def compute_frame_vs_copy(self) -> float:
        return self.compute_frame_s / self.copy_s

    @property
    def gs_tf_update_vs_copy(self) -> float:
        return self.gs_tf_update_s / self.copy_s

    @property
    def compute_update_vs_copy(self) -> float:
        return self.compute_update_s / self.copy_s

    @property
    def gs_tf_vs_numpy(self) -> float | None:
        """Speedup of the GS/TF frame over the numpy float32 twin's step."""
        return None if self.numpy_s is None else self.numpy_s / self.gs_tf_frame_s

    @property
    def gs_tf_portable_cost(self) -> float:
        """How many times longer a portable-arithmetic GS/TF frame takes than a native one."""
        return self.gs_tf_portable_frame_s / self.gs_tf_frame_s

    @property
    def compute_portable_cost(self) -> float:
        """The same on the compute path."""
        return self.compute_portable_frame_s / self.compute_frame_s

    @property
    def checksum_share(self) -> float:
        """Checksum time as a share of the compute path's whole frame."""
        return self.checksum_s / self.compute_frame_s

    def seconds(self, path: str) -> float | None:
        return getattr(self, f"{path}_s")

    def particles_per_s(self, path: str) -> float | None:
        seconds = self.seconds(path)
        return None if seconds is None else self.particles / seconds

    def ratio(self, name: str) -> float | None:
        return getattr(self, name)

    def to_json(self) -> dict[str, object]:
        return {
            "particles": self.particles,
            "frames": {path: self.frames[path] for path in PATHS},
            "seconds": {path: self.seconds(path) for path in PATHS},
            "particles_per_s": {path: self.particles_per_s(path) for path in PATHS},
            "ratios": {name: self.ratio(name) for name in RATIOS},
            "live_after": self.live_after,
        }


@dataclass(frozen=True)
class Target:
    ratio: str  # one of RATIOS
    comparison: str  # ">=" or "<="
    bound: float
    meaning: str
    particles: int  # the size it is judged at when measured, else the largest measured
    renderer: str  # where the target applies: "llvmpipe" or "GPU"

    def met_by(self, value: float) -> bool:
        return {">=": operator.ge, "<=": operator.le}[self.comparison](value, self.bound)

    def applies(self, software: bool) -> bool:
        """Whether the target is meant for a renderer of this kind (software: llvmpipe)."""
        return applies_to(self.renderer, software)

    def evaluate(self, sizes: list[SizeFigures], software: bool) -> dict[str, object]:
        """Judged among the sizes that measured the ratio, on the renderer it is meant for
        (`met` None elsewhere, `applies` False); `measured`, `met` and `particles` are None
        where no size measured it (the numpy twin above its cap)."""
        target = {"name": self.ratio, "meaning": self.meaning, "comparison": self.comparison,
                  "target": self.bound, "renderer": self.renderer,
                  "applies": self.applies(software)}
        measured = [figures for figures in sizes if figures.ratio(self.ratio) is not None]
        if not measured:
            return {**target, "measured": None, "met": None, "particles": None}
        figures = judged_size(measured, self.particles)
        value = figures.ratio(self.ratio)
        return {**target, "measured": value,
                "met": self.met_by(value) if target["applies"] else None,
                "particles": figures.particles}


SOFTWARE_RENDERER = "llvmpipe"  # a Target's renderer: this, or "GPU"


def applies_to(renderer: str, software: bool) -> bool:
    """Whether a target meant for `renderer` is judged on a renderer of this kind (software:
    llvmpipe): a GPU's figures say nothing of llvmpipe's target, nor llvmpipe's of a GPU's."""
    return (renderer == SOFTWARE_RENDERER) == software
# The engine's targets (the compute path's, the numpy and checksum ones), each at its reference size
TARGETS = (
    Target("compute_speedup", ">=", 3.0, "compute frame speedup over the GS/TF frame",
           1_000_000, "llvmpipe"),
    Target("compute_frame_vs_copy", "<=", 3.0, "compute frame against the copy bound",
           10_000_000, "GPU"),
    Target("gs_tf_vs_numpy", ">=", 10.0, "GS/TF frame speedup over the numpy float32 twin",
           1_000_000, "llvmpipe"),
    Target("checksum_share", "<=", 0.10, "checksum time per compute frame", 1_000_000,
           "llvmpipe"),
)


def judged_size(sizes: list[SizeFigures], particles: int) -> SizeFigures:
    """The size a target is judged at: `particles` if measured, else the largest."""
    for figures in sizes:
        if figures.particles == particles:
            return figures
    return max(sizes, key=lambda f: f.particles)


def evaluate_targets(sizes: list[SizeFigures], software: bool) -> list[dict[str, object]]:
    """Each target judged, on a software renderer (llvmpipe) or a GPU."""
    return [target.evaluate(sizes, software) for target in TARGETS]
