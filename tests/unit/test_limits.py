"""The particle state's limits: one value in cavesim/core/limits.py, the same in the GLSL
that drops particles past them, and a scene that would launch past them refused."""

import re

import numpy as np
import pytest

from cavesim.core.errors import SceneError
from cavesim.core.frame import FrameInput
from cavesim.core.limits import MAX_LAUNCH_SPEED, RUNAWAY, SPEED_LIMIT
from cavesim.core.records import PARTICLE_DTYPE
from cavesim.core.scene import Integrator, parse_scene
from cavesim.core.twin.system import TwinSystem
from cavesim.gpu.shader_source import SHADER_ROOT
from cavesim.tools.stability.extremes import busy_scene, busy_scene_data

PHYSICS = SHADER_ROOT / "include" / "physics.glsl"


@pytest.mark.parametrize(("name", "value"), [("RUNAWAY", RUNAWAY), ("SPEED_LIMIT", SPEED_LIMIT)])
def test_the_shaders_hold_the_same_limits(name, value):
    [literal] = re.findall(rf"const float {name} = ([0-9.e+]+);", PHYSICS.read_text())
    assert float(literal) == value


def test_an_emitter_launching_past_the_limit_is_refused_with_one_line():
    data = busy_scene_data()
    data["emitter"][0]["speed"] = MAX_LAUNCH_SPEED
    parse_scene(data, name="fast")  # at the bound: fine
    data["emitter"][0]["speed"] = 1e14
    with pytest.raises(SceneError, match=r"emitter\[0\]\.speed = 100000000000000\.0 is not "
                                         r"allowed: must be a finite number >= 0 and <= "
                                         r"2\.5e\+06"):
        parse_scene(data, name="fast")


def test_the_twin_drops_a_particle_faster_than_the_limit_before_or_after_a_step():
    """Started past the limit: dropped; just inside it, with drag: kept and slowed. (The
    GPU's side: tests/gpu/test_stability.py, "dust launched at 1e14 m/s".)"""
    twin = TwinSystem(busy_scene(Integrator.ETD2RK, emitters=False))
    launched = np.zeros(3, dtype=PARTICLE_DTYPE)
    launched["pos"] = (0.0, 0.0, 1.0)
    launched["vel"][:, 0] = (1e14, 0.99 * SPEED_LIMIT, 1.0)
    launched["lifetime"] = 1e6
    twin.write_particles(launched)
    twin.step(FrameInput(np.float32(1 / 60), np.eye(3, dtype=np.float32)))
    speeds = np.abs(twin.particles.vel).max(axis=1)
    assert len(speeds) == 2 and speeds[0] < 0.99 * SPEED_LIMIT and speeds[1] < 2.0
