"""What one benchmark size measured (median seconds per path) and the targets it is held to.

`TARGETS` is the one table the report and the tests both read, so they cannot drift apart.
"""

from __future__ import annotations

import operator
from dataclasses import dataclass

PATHS = ("gs_tf", "compute", "numpy", "checksum")
RATIOS = ("gs_tf_vs_numpy", "gs_tf_vs_compute", "checksum_share")


@dataclass(frozen=True)
class SizeFigures:
    particles: int
    gs_tf_s: float  # one ParticleSystem.step + ctx.finish()
    compute_s: float  # one in-place compute-shader pass of the same arithmetic + ctx.finish()
    numpy_s: float  # one TwinSystem(float32).step
    checksum_s: float  # one ParticleSystem.checksum()
    gpu_frames: int  # timed frames of the three GL paths (after the warm-up)
    numpy_frames: int  # timed frames of the numpy twin
    live_after: int  # live particles after the GS/TF frames: all of them, nothing dies

    @property
    def gs_tf_vs_numpy(self) -> float:
        """Speedup of the GS/TF step over the numpy float32 twin."""
        return self.numpy_s / self.gs_tf_s

    @property
    def gs_tf_vs_compute(self) -> float:
        """Slowdown of the GS/TF step against the in-place compute-shader bound."""
        return self.gs_tf_s / self.compute_s

    @property
    def checksum_share(self) -> float:
        """Checksum time as a share of one GS/TF step."""
        return self.checksum_s / self.gs_tf_s

    def seconds(self, path: str) -> float:
        return getattr(self, f"{path}_s")

    def particles_per_s(self, path: str) -> float:
        return self.particles / self.seconds(path)

    def ratio(self, name: str) -> float:
        return getattr(self, name)

    def to_json(self) -> dict[str, object]:
        return {
            "particles": self.particles,
            "frames": {"gs_tf": self.gpu_frames, "compute": self.gpu_frames,
                       "checksum": self.gpu_frames, "numpy": self.numpy_frames},
            "seconds": {path: self.seconds(path) for path in PATHS},
            "particles_per_s": {path: self.particles_per_s(path) for path in PATHS},
            "ratios": {name: self.ratio(name) for name in RATIOS},
            "live_after_gs_tf": self.live_after,
        }


@dataclass(frozen=True)
class Target:
    ratio: str  # one of RATIOS
    comparison: str  # ">=" or "<="
    bound: float
    meaning: str

    def met_by(self, value: float) -> bool:
        return {">=": operator.ge, "<=": operator.le}[self.comparison](value, self.bound)

    def evaluate(self, figures: SizeFigures) -> dict[str, object]:
        value = figures.ratio(self.ratio)
        return {"name": self.ratio, "meaning": self.meaning, "comparison": self.comparison,
                "target": self.bound, "measured": value, "met": self.met_by(value),
                "particles": figures.particles}


# The targets for this 2-core machine with software GL, at the reference size
TARGET_PARTICLES = 1_000_000  # the reference size when measured, else the largest one
TARGETS = (
    Target("gs_tf_vs_numpy", ">=", 10.0, "GS/TF step speedup over the numpy float32 twin"),
    Target("gs_tf_vs_compute", "<=", 1.5, "GS/TF step slowdown against the compute bound"),
    Target("checksum_share", "<=", 0.10, "checksum time per GS/TF step"),
)


def reference_size(sizes: list[SizeFigures]) -> SizeFigures:
    """The size the targets are judged at: 1M particles if measured, else the largest."""
    for figures in sizes:
        if figures.particles == TARGET_PARTICLES:
            return figures
    return max(sizes, key=lambda f: f.particles)


def evaluate_targets(sizes: list[SizeFigures]) -> list[dict[str, object]]:
    reference = reference_size(sizes)
    return [target.evaluate(reference) for target in TARGETS]
