"""`cavesim bench --render`: the files a tiny run writes, its line per measurement, the
renderer's GPU target left unjudged on llvmpipe and judged on a GPU, its flags.

The benchmark runs `nodes.cli.main` in a child process: it opens its own EGL context, and a
second context in the test process would become current in place of `gl_session`.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from cavesim.core.cave import DEFAULT_CAVE
from cavesim.core.cave.geometry import load_cave
from cavesim.tools.bench.render_cost import RENDER_TARGET, DrawCost, front_wall
from cavesim.tools.bench.render_report import target_line
from nodes.cli import main

ROOT = Path(__file__).parents[2]
RUN_MAIN = "import sys; from nodes.cli import main; sys.exit(main(sys.argv[1:]))"
SIZES = (1000, 3000)
RESOLUTIONS = ((32, 32), (48, 30))
pytestmark = pytest.mark.xdist_group("bench_render")  # one tiny run, on one worker


@pytest.fixture(scope="module")
def render_run(tmp_path_factory):
    """Two tiny pools at two tiny walls, 3 timed draws each."""
    work = tmp_path_factory.mktemp("bench_render")
    out = work / "reports"
    argv = ["bench", "--render", "--sizes", ",".join(map(str, SIZES)), "--resolutions",
            ",".join(f"{w}x{h}" for w, h in RESOLUTIONS), "--frames", "3", "--out", str(out)]
    done = subprocess.run([sys.executable, "-c", RUN_MAIN, *argv], cwd=work,
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    return done, out, json.loads((out / "bench-render.json").read_text())


def test_json_has_a_measurement_per_pool_and_wall(render_run):
    _, out, report = render_run
    assert report["command"] == "bench --render" and report["ended"] == "complete"
    assert report["scene"]["name"] == "brownout" and report["draws"] == 3
    assert len(report["load_average"]) == 3
    got = [(m["particles"], tuple(m["resolution"])) for m in report["measurements"]]
    assert got == [(n, r) for n in SIZES for r in RESOLUTIONS]
    for m in report["measurements"]:
        assert m["pool"] and m["draws"] == 3
        assert 0 < m["p50_ms"] <= m["p90_ms"] and m["draws_per_s"] > 0
        assert m["particles_per_s"] > 0
        width, height = m["wall_m"]
        assert width / height == pytest.approx(m["resolution"][0] / m["resolution"][1])
    assert (out / "bench-render.md").read_text().startswith("# cavesim bench --render")


def test_on_llvmpipe_the_gpu_target_is_not_judged(render_run):
    done, out, report = render_run
    target = report["target"]
    assert report["software"] and target["renderer"] == "GPU"
    assert (target["applies"], target["met"], target["measured_ms"]) == (False, None, None)
    verdict = "not judged: a GPU target, and this renderer is not one"
    assert verdict in done.stdout and "NOT met" not in done.stdout
    assert verdict in (out / "bench-render.md").read_text()


def test_prints_a_line_per_measurement_with_a_rate_before_the_table(render_run):
    done, _, _ = render_run
    lines = done.stdout.splitlines()
    table = next(k for k, line in enumerate(lines) if "wall px" in line)
    lines = [line for line in lines[:table] if "draws/s" in line and " p50 " in line]
    assert len(lines) == len(SIZES) * len(RESOLUTIONS)
    assert "pool of 1,000" in lines[0] and "32x32" in lines[0]


def cost(ms: float, particles: int = 1_000_000, resolution=(1920, 1200)) -> DrawCost:
    return DrawCost("pool", particles, True, resolution, (3.0, 1.875), (ms * 1e-3,) * 3)


@pytest.mark.parametrize(("costs", "met", "measured"), [
    ([cost(3.5)], True, 3.5),
    ([cost(4.5)], False, 4.5),
    ([cost(1.0, resolution=(480, 480)), cost(9.0)], False, 9.0),
    ([cost(1.0, particles=500_000)], None, None),
])
def test_on_a_gpu_the_target_is_judged_at_its_size_and_resolution(costs, met, measured):
    target = RENDER_TARGET.evaluate(costs, software=False)
    assert target["applies"] and target["met"] is met
    assert target["measured_ms"] == pytest.approx(measured) if measured else \
        target["measured_ms"] is None
    assert ("NOT met" in target_line(target)) == (met is False)


def test_the_wall_drawn_keeps_pixels_square_and_flex4s_width():
    front = load_cave(ROOT / DEFAULT_CAVE).wall("front")
    assert front_wall(front, (480, 480)) == front
    hd = front_wall(front, (1920, 1200))
    assert (hd.width, hd.height, hd.resolution) == (3.0, 1.875, (1920, 1200))
    assert hd.center[2] == pytest.approx(1.5)


@pytest.mark.parametrize(("flags", "message"), [
    (["--resolutions", "480"], "argument --resolutions: expected comma-separated WIDTHxHEIGHT"),
    (["--resolutions", "480x5"], "argument --resolutions: expected comma-separated WIDTHxHEIGHT"),
    (["--sizes", "100", "--at-frame", "3"], "argument --at-frame: not with --sizes"),
    (["--cluster"], "argument --cluster: not with --render"),
])
def test_bad_render_flags_are_one_line(flags, message, capsys, tmp_path):
    assert main(["bench", "--render", *flags, "--out", str(tmp_path / "o")]) == 2
    assert message in capsys.readouterr().err


def test_render_flags_only_with_render(capsys, tmp_path):
    assert main(["bench", "--resolutions", "32x32", "--out", str(tmp_path / "o")]) == 2
    assert "argument --resolutions: only with --render" in capsys.readouterr().err
