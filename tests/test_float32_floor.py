"""The float32 floor of every integrator: RMS |GPU - float64 twin| at the accuracy report's
finest dts, at most 5e-6 m where the stored state allows it, and at the storage floor
(cavesim/tools/numerics/storage.py) everywhere.

Forms that rounded a decay weight near 1 every step (the exponential step's e^-x, semi-implicit
Euler's 1 / (1 + h lambda)) or moved the position in two additions failed this by 2x-20x at
1/480 and 1/960 s (5.8e-5 m for the exponential step in the vortex).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from cavesim.core.scene.model import Integrator
from cavesim.tools.numerics.cases import DTS, FINAL_TIME, build_cases
from cavesim.tools.numerics.results import rms_and_max
from cavesim.tools.numerics.runs import MANUAL, gpu_runs, twin_runs
from cavesim.tools.numerics.storage import storage_floors

PARTICLES = 500
FINEST = DTS[-2:]  # 1/480 and 1/960 s: where the floor is highest
FLOOR_LIMIT = 5e-6  # m, issue 16
STORAGE_FACTOR = 1.3  # a float32 floor this close to the storage floor is at it
SCENE = Path(__file__).parents[1] / "config" / "scenes" / "brownout.toml"


@pytest.fixture(scope="module")
def cases():
    return {case.name: case for case in build_cases(SCENE, PARTICLES)}


@pytest.fixture(scope="module")
def storage(cases):
    return {name: storage_floors(case, Integrator.RK4, FINEST, FINAL_TIME)
            for name, case in cases.items()}


@pytest.mark.parametrize("integrator", list(Integrator), ids=lambda i: i.value)
def test_float32_floor_is_the_storage_floor_and_at_most_5e6_m(gl_session, cases, storage,
                                                              integrator):
    for name, case in cases.items():
        gpu = gpu_runs(gl_session, case, integrator, MANUAL, FINEST, FINAL_TIME)
        twin = twin_runs(case, integrator, FINEST, FINAL_TIME)
        for g, t, floor in zip(gpu, twin, storage[name], strict=True):
            measured = rms_and_max(g.pos, t.pos)[0]
            assert measured <= STORAGE_FACTOR * floor, (name, g.dt, measured, floor)
            if name != "downwash":  # its ~14 m positions store ~1e-5 m (see the module)
                assert measured <= FLOOR_LIMIT, (name, g.dt, measured)


def test_the_storage_floor_is_the_random_walk_of_float32_rounding(cases, storage):
    """~ ulp(|p|) / sqrt(12) per component and step, random-walked: for the uniform case's
    ~3 m positions (ulp 2.4e-7 m) over 960 steps, sqrt(3 * 960 / 12) * 2.4e-7 = 3.7e-6 m,
    a little less where positions are under 2 m; and twice as many steps give sqrt(2) more."""
    uniform = storage["uniform"]
    assert 1e-6 < uniform[1] < 3.7e-6
    assert uniform[1] / uniform[0] == pytest.approx(np.sqrt(2), rel=0.25)
    assert storage["downwash"][1] > 3 * uniform[1]  # positions ~5x larger
