"""benchmarks/parcels_vortex.py's cavesim part at 1,000 particles, so that the script cannot
rot: it runs, prints its tables and writes its JSON, and the RK4 error it reports for both
engine paths is cavesim's, within 2e-7 m of the rotation in closed form and not zero (which
a comparison of a run with itself would give). Parcels is left out (--cavesim-only)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from benchmarks.vortex_case import position_errors, start_positions
from cavesim.tools.numerics.solid_body import rotated

SCRIPT = Path(__file__).resolve().parents[2] / "benchmarks" / "parcels_vortex.py"
RMS_LIMIT = 2e-7  # m, RK4 on the GPU after 1 s (tests/gpu/test_tracer_accuracy.py)
RMS_FLOOR = 1e-9  # m: the float32 grid alone leaves more than this


def test_the_script_reports_cavesims_rk4_error_within_2e_7_m(tmp_path):
    out = tmp_path / "results.json"
    done = subprocess.run([sys.executable, str(SCRIPT), "--sizes", "1000", "--out", str(out),
                           "--cavesim-only"], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert "| particles | Parcels s/step | cavesim GS/TF s/step (speed-up)" in done.stdout
    assert "| 1,000 | - |" in done.stdout
    runs = json.loads(out.read_text())["sizes"][0]["runs"]
    for path in ("gs_tf", "compute"):
        rms = runs[path]["rms_m"]
        assert RMS_FLOOR < rms <= RMS_LIMIT, f"{path}: RMS {rms:.3g} m"
        assert f"RMS {rms:.2e} m" in done.stdout


def test_a_bad_flag_is_one_line_without_a_traceback():
    done = subprocess.run([sys.executable, str(SCRIPT), "--sizes", "10,x"],
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 2
    assert done.stdout == "" and len(done.stderr.splitlines()) == 1, done.stderr


def test_position_errors_are_distances_to_the_rotated_start():
    start = start_positions(100)
    offset = np.zeros_like(start)
    offset[::2, 0] = 3e-7  # half the particles 3e-7 m off
    rms, worst = position_errors(start, rotated(start, 1.0) + offset, 1.0)
    assert rms == pytest.approx(3e-7 / np.sqrt(2), rel=1e-6)
    assert worst == pytest.approx(3e-7, rel=1e-6)
