"""The physics features of the particle pass, one room each.

A feature module declares, in one place, everything the feature adds (`feature.py` says
what): its scene keys, what it requires and excludes, its `#define`s with the values they
take, its uniforms and textures, its GLSL include, its twin and portable kernels, and, by
the `Coordinate` marks on its keys, the coordinates the scene's origin moves. The hubs
iterate over the features a scene has (`registry.FEATURES`, `features_of`): the shader
programs (cavesim/gpu/engine/programs.py), the engine (`ParticleSystem`), the twins
(cavesim/core/twin/system.py) and the loader's rules (`rules.py`). Nothing else names a
feature.

Modules named like others are the same feature's declaration beside its kernels:
`dispersion`, `collision` and `tracers` (cavesim/core/twin/, the float64 twin's; the
portable arithmetic's are in cavesim/core/portable/). This package imports none of its
modules: the scene model imports the tables some of them hold.
"""
