"""Pictures of a run: each wall's view, the unfolded-CAVE composite, the run's animation."""

from cavesim.gpu.render.animation import write_animation
from cavesim.gpu.render.composite import compose, compose_run
from cavesim.gpu.render.unfold import unfold_layout

__all__ = ["compose", "compose_run", "unfold_layout", "write_animation"]
