"""The selection rule: birth indices that are multiples of S below N·S, S from the births the
scene is expected to make over the run (a helicopter's rate factors included)."""

import numpy as np
import pytest
from fountain import DT, fountain

from cavesim.core.scene import load_scene
from cavesim.core.trajectories import Selection
from cavesim.core.trajectories.identity import expected_births


def test_a_still_scene_expects_its_rates_times_the_run():
    assert expected_births(fountain(rate=300.0), 600, DT) == pytest.approx(3000.0)
    assert Selection.for_run(fountain(rate=300.0), 50, 600, DT) == Selection(50, 60)


def test_at_most_n_are_tracked_every_stride_th():
    selection = Selection(count=4, stride=10)
    ids = np.arange(100, dtype=np.uint64)
    assert ids[selection.tracked(ids)].tolist() == [0, 10, 20, 30]


def test_a_helicopter_scene_counts_the_rotors_rate_factors():
    """The brownout demo emits several times its emitters' rates (the rotor's saltation);
    past its 900 scripted frames the last frame's rate holds."""
    scene = load_scene("config/scenes/brownout.toml")
    nominal = sum(e.rate for e in scene.emitters) * 300 * DT
    assert expected_births(scene, 300, DT) > 5 * nominal
    scripted, later = expected_births(scene, 900, DT), expected_births(scene, 960, DT)
    assert later - scripted == pytest.approx(60 * (scripted - expected_births(scene, 899, DT)))


@pytest.mark.parametrize("count", [0, 1_000_001])
def test_a_count_outside_the_bound_is_refused(count):
    with pytest.raises(ValueError, match=r"trajectories must be in \[1, 1000000\]"):
        Selection.for_run(fountain(), count, 100, DT)
