"""What a physics feature declares: the room a feature of the particle pass lives in.

A feature is a subclass of `Feature` in a module of its own, with one instance the registry
lists. Everything it adds to a frame is a hook here, with a default that adds nothing, so a
new feature writes only what it has:

  - scene: `keys` (the dotted keys it owns; a table of its own is defined in its module),
    `present(scene)`, `complete(scene)` for what it decides of the scene (a default from
    the others' keys), `check(scene)` for rules about its own keys, `where(scene, key)` to
    name the offending key of a broken rule;
  - shader: `defines` (each with the values it may take, the first meaning off),
    `define_values(scene)`, `rules` (what it requires and excludes, `rules.Rule`),
    `include` (its GLSL, pasted into the particle pass);
  - data: `load(scene, random)` once per scene (numpy: a grid, heights, per-class constants), then
    `textures` and `uniforms` from it, and `frame_uniforms` each frame;
  - twins: `force_terms` (its part of the force model), `seen` (what the particles see
    besides the flow this step), `after_move` (what happens after the integrator's step);
    a hook picks the twin's or the portable kernel by `kernels.portable`.
A position key says so with `Coordinate` (cavesim.core._schema) and the origin moves it.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from cavesim.core.fields.snapshot_time import FIRST_SNAPSHOT, FieldTime

if TYPE_CHECKING:
    from cavesim.core.features.rules import Rule
    from cavesim.core.frame import FrameInput

# The scene model imports the tables features hold, so a feature names these types without
# importing them (not even for type checks: no module imports another in a circle)
Scene = Any  # cavesim.core.scene.model.Scene
Kernels = Any  # cavesim.core.twin.kernels.Kernels: a twin's arithmetic
FrameRotor = Any  # cavesim.core.helicopter.inputs.FrameRotor: a helicopter's rotor this frame


@dataclass(frozen=True)
class Texture:
    """A texture a feature's GLSL samples with texelFetch (or, `linear`, the texture unit's
    filter): its sampler uniform's name and its texels, (h, w, c) or (d, h, w, c), float32 or
    uint32, uploaded as they are; `what` it is and what to have `fewer` of, for the line that
    refuses one beyond the context's limits."""

    name: str
    texels: np.ndarray
    linear: bool = False
    what: str = ""
    fewer: str = "texels"

    @property
    def size(self) -> tuple[int, ...]:
        """(w, h) or (w, h, d), as GL takes it."""
        return tuple(reversed(self.texels.shape[:-1]))

    @property
    def components(self) -> int:
        return self.texels.shape[-1]

    @property
    def dtype(self) -> str:
        return {np.dtype(np.float32): "f4", np.dtype(np.uint32): "u4"}[self.texels.dtype]


@dataclass(frozen=True)
class FrameState:
    """What a frame gives the features beside the scene: its inputs, the helicopter's rotor
    (a helicopter scene's) and where a time-series field is."""

    frame: FrameInput | None = None
    rotor: FrameRotor | None = None
    field_time: FieldTime = FIRST_SNAPSHOT


NO_FRAME = FrameState()  # a state outside any frame: no rotor, a series at its start


class Feature:
    """One physics feature of the particle pass (this module's docstring says how)."""

    name: ClassVar[str] = ""
    keys: ClassVar[tuple[str, ...]] = ()
    defines: ClassVar[Mapping[str, tuple[int, ...]]] = {}
    rules: ClassVar[tuple[Rule, ...]] = ()
    include: ClassVar[str | None] = None  # under cavesim/gpu/shaders/include/
    draws_random: ClassVar[bool] = False  # its code reads the random texture

    # -- the scene ------------------------------------------------------------------------

    def present(self, scene: Scene) -> bool:
        """Whether the scene has this feature (else its code is compiled out)."""
        return False

    def complete(self, scene: Scene) -> Scene:
        """The scene with what the feature decides of it filled in (by default, as it is)."""
        return scene

    def check(self, scene: Scene) -> None:
        """Refuse what is wrong with its own keys in one line (SceneError), whether or not
        the scene has the feature; the rules between features are `rules`'."""

    def where(self, scene: Scene, key: str) -> tuple[str, Any]:
        """The dotted key, with its index where it is an array's, and the value a broken rule
        about `key` names (None: the key is a table)."""
        return key, None

    def define_values(self, scene: Scene) -> dict[str, int]:
        """Its defines for a scene that has it: by default each the last of its values (on)."""
        return {name: values[-1] for name, values in self.defines.items()}

    def off(self) -> dict[str, int]:
        """Its defines for a scene without it."""
        return {name: values[0] for name, values in self.defines.items()}

    # -- its data -------------------------------------------------------------------------

    def load(self, scene: Scene, random: np.ndarray | None) -> Any:
        """What it needs of the scene's files and tables, once, and of the random texture's
        words `random` where it `draws_random` (again when the seed changes): None, nothing."""
        return None

    def textures(self, scene: Scene, data: Any) -> tuple[Texture, ...]:
        return ()

    def uniforms(self, scene: Scene, data: Any) -> dict[str, Any]:
        """The particle pass's constants, as the exact bits they go up with."""
        return {}

    def frame_uniforms(self, scene: Scene, data: Any, state: FrameState | None
                       ) -> dict[str, Any]:
        """What changes each frame; its values before the first frame for `state` None."""
        return {}

    # -- the twins ------------------------------------------------------------------------

    def force_terms(self, scene: Scene, data: Any, kernels: Kernels, class_id: np.ndarray,
                    state: FrameState) -> dict[str, Any]:
        """Its terms of the force model (`kernels.forces`' arguments) for particles of
        classes `class_id`."""
        return {}

    def seen(self, scene: Scene, data: Any, kernels: Kernels, twin: Any, forces: Any,
             state: FrameState) -> dict[str, Any]:
        """Terms the particles see besides the flow this step, from the force model of the
        flow alone (dispersion's turbulence)."""
        return {}

    def after_move(self, scene: Scene, data: Any, kernels: Kernels, pos: np.ndarray,
                   vel: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The particles after the integrator's step (a collision's bounce)."""
        return pos, vel
