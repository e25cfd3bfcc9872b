"""Every physics feature, in the order the particle pass composes them, and what follows
from the list: a scene's features, the particle pass's defines and the values they take, the
ids its GLSL compares them with, and the rule table.

Adding a feature is a module of its own in this package and a line in FEATURES.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from typing import TYPE_CHECKING, Any

import numpy as np

from cavesim.core.features.collision import COLLISION
from cavesim.core.features.coriolis import CORIOLIS
from cavesim.core.features.damping import DAMPING
from cavesim.core.features.dispersion import DISPERSION
from cavesim.core.features.feature import Feature
from cavesim.core.features.gravity import GRAVITY
from cavesim.core.features.grid_flow import GRID_FLOW
from cavesim.core.features.origin import ORIGIN
from cavesim.core.features.rotor_wash import ROTOR_WASH
from cavesim.core.features.rules import Rule, check_scene, holds
from cavesim.core.features.schiller_naumann import SCHILLER_NAUMANN
from cavesim.core.features.stokes_drag import STOKES_DRAG
from cavesim.core.features.time_series import TIME_SERIES
from cavesim.core.features.tracers import TRACERS
from cavesim.core.limits import MAX_PARTICLE_CLASSES
from cavesim.core.scene.model import Arithmetic, Integrator

if TYPE_CHECKING:
    from cavesim.core.scene.model import Scene

FEATURES: tuple[Feature, ...] = (
    GRAVITY, DAMPING, CORIOLIS, STOKES_DRAG, SCHILLER_NAUMANN, GRID_FLOW, TIME_SERIES, ROTOR_WASH,
    TRACERS, COLLISION, DISPERSION, ORIGIN)

# What every particle pass is compiled with besides its features: the arithmetic, the
# integrator and the number of particle classes (each define with the values it may take)
BASE_DEFINES: dict[str, tuple[int, ...]] = {
    "ARITHMETIC": tuple(range(len(Arithmetic))),
    "INTEGRATOR": tuple(sorted(i.gpu_id for i in Integrator)),
    "CLASS_COUNT": (1, MAX_PARTICLE_CLASSES),
}
# The ids the particle pass's conditions compare its defines with (`#define NAME id` in its
# preamble); a feature's are its own
BASE_IDS: dict[str, int] = {
    **{f"ARITHMETIC_{a.name}": n for n, a in enumerate(Arithmetic)},
    **{f"INTEGRATOR_{i.name}": i.gpu_id for i in Integrator},
}
IDS: dict[str, int] = {**BASE_IDS, **{name: number for feature in FEATURES
                                      for name, number in getattr(feature, "ids", {}).items()}}
# the ids the particle pass's preamble defines: all but the arithmetic's (arithmetic.glsl
# defines those, for every program)
GLSL_IDS: dict[str, int] = {name: number for name, number in IDS.items()
                            if not name.startswith("ARITHMETIC_")}
PASS_DEFINES: dict[str, tuple[int, ...]] = {
    **BASE_DEFINES, **{name: values for feature in FEATURES
                       for name, values in feature.defines.items()}}
RULES: tuple[Rule, ...] = tuple(rule for feature in FEATURES for rule in feature.rules)


def features_of(scene: Scene) -> tuple[Feature, ...]:
    """The features a scene has, in FEATURES' order."""
    return tuple(feature for feature in FEATURES if feature.present(scene))


def pass_defines(scene: Scene) -> dict[str, int]:
    """The particle pass's defines for a scene: its features' values, every other feature's
    off values."""
    values = {"ARITHMETIC": list(Arithmetic).index(scene.arithmetic),
              "INTEGRATOR": scene.integrator.gpu_id,
              "CLASS_COUNT": max(1, len(scene.particle_classes))}
    for feature in FEATURES:
        values |= feature.define_values(scene) if feature.present(scene) else feature.off()
    return values


def completed(scene: Scene) -> Scene:
    """A scene as the loader built it, completed by its features in FEATURES' order (a
    class's drag law; the origin last, taken from every coordinate); SceneError for what
    they refuse: each one's own keys, then the rules between them."""
    for feature in FEATURES:
        scene = feature.complete(scene)
        feature.check(scene)
    check_scene(scene, FEATURES, {**IDS, **pass_defines(scene)},
                str(scene.source) if scene.source is not None else "<dict>")
    return scene


def possible(values: Mapping[str, int]) -> bool:
    """Whether a combination of the particle pass's defines keeps every rule: one a scene
    can make (the shader gate compiles only these)."""
    return holds(RULES, {**IDS, **values})


class FeatureData(Mapping[str, Any]):
    """What each feature of a scene loads (`Feature.load`), by its name, loaded once: the
    engine's textures and uniforms and the twins' force terms read the same data."""

    def __init__(self, scene: Scene, random: np.ndarray | None) -> None:
        self._data = {feature.name: feature.load(scene, random if feature.draws_random
                                                 else None) for feature in features_of(scene)}

    def reload(self, feature: Feature, scene: Scene, random: np.ndarray | None) -> None:
        """Load one feature's data again (a new seed: new random words)."""
        self._data[feature.name] = feature.load(scene, random if feature.draws_random else None)

    def __getitem__(self, name: str) -> Any:
        return self._data[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self._data)

    def __len__(self) -> int:
        return len(self._data)
