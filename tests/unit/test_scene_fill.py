"""The shipped helicopter scenes are sized for what their emitters put out: the demo stays
under its capacity, brownout_10m fills its 10 million."""

from pathlib import Path

import numpy as np
import pytest

from cavesim.core.helicopter.expected_fill import expected_live
from cavesim.core.scene import load_scene

SCENES = Path(__file__).parents[2] / "config" / "scenes"


def test_the_demo_peaks_under_its_capacity_and_the_10m_scene_fills_its_pool():
    demo, big = (load_scene(SCENES / name) for name in ("brownout.toml", "brownout_10m.toml"))
    demo_live, big_live = expected_live(demo), expected_live(big)
    assert 200_000 < demo_live.max() < demo.capacity  # a run reports ~240,000 at the peak
    assert big.capacity == 10_000_000 and big_live.max() > big.capacity
    assert np.argmax(big_live > big.capacity) < len(big_live)  # full before the end
    np.testing.assert_allclose(big_live, 45 * demo_live, rtol=1e-9)  # the same cloud, 45x
    assert 4 * big.random_texture_size ** 2 > big.capacity  # a word per particle a frame
    assert big.helicopter == demo.helicopter and big.particle_classes == demo.particle_classes


def test_a_scene_without_a_timeline_has_no_expected_fill():
    with pytest.raises(ValueError, match="no helicopter timeline"):
        expected_live(load_scene(SCENES / "minimal.toml"))
