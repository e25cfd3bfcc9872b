"""`cavesim bench`: the reports it writes, the figures in them, and its answer to bad flags.

The benchmark runs `cavesim.tools.cli.main` in a child process: it opens its own EGL context, and
a second context in the test process would become current in place of `gl_session`.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys

import pytest

from cavesim.core.limits import MAX_PARTICLES
from cavesim.core.scene import load_scene
from cavesim.gpu.engine.capacity import capacity_limits
from cavesim.tools.arguments import REPO_ROOT
from cavesim.tools.bench import TARGETS, SizeFigures
from cavesim.tools.bench.figures import PATHS, RATIOS, evaluate_targets
from cavesim.tools.bench.measure import measure_size
from cavesim.tools.bench.runner import DEFAULT_SIZES, default_sizes
from cavesim.tools.bench.workload import frame_inputs
from cavesim.tools.cli import main

SIZES = (2000, 5000)
RUN_MAIN = "import sys; from cavesim.tools.cli import main; sys.exit(main(sys.argv[1:]))"


@pytest.fixture(scope="module")
def bench_run(tmp_path_factory):
    """One small benchmark run from a directory outside the repository (default scene)."""
    work = tmp_path_factory.mktemp("bench")
    out = work / "reports"
    argv = ["bench", "--sizes", ",".join(map(str, SIZES)), "--frames", "2", "--out", str(out)]
    done = subprocess.run([sys.executable, "-c", RUN_MAIN, *argv], cwd=work,
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    return done, out, json.loads((out / "bench.json").read_text())


def test_prints_the_table_targets_and_paths(bench_run):
    done, out, _ = bench_run
    assert "speedup" in done.stdout and "5,000" in done.stdout
    assert done.stdout.count(" particles (") == len(TARGETS)
    assert f"wrote {out / 'bench.json'}" in done.stdout
    assert f"wrote {out / 'bench.md'}" in done.stdout


def test_json_has_every_size_with_positive_finite_figures(bench_run):
    _, _, report = bench_run
    assert report["command"] == "bench" and report["scene"]["name"] == "bench"
    assert report["frames"] == 2 and report["gl"]["renderer"]
    assert [size["particles"] for size in report["sizes"]] == list(SIZES)
    assert report["skipped_sizes"] == []
    for size in report["sizes"]:
        assert set(size["seconds"]) == set(PATHS) and set(size["ratios"]) == set(RATIOS)
        figures = [*size["seconds"].values(), *size["particles_per_s"].values(),
                   *size["ratios"].values()]
        assert all(math.isfinite(x) and x > 0 for x in figures), size
        assert size["live_after"] == size["particles"]


def test_ratios_and_rates_follow_from_the_times(bench_run):
    _, _, report = bench_run
    for size in report["sizes"]:
        s, ratios = size["seconds"], size["ratios"]
        assert ratios["compute_speedup"] == pytest.approx(s["gs_tf_frame"] / s["compute_frame"])
        for path in ("gs_tf_frame", "compute_frame", "gs_tf_update", "compute_update"):
            assert ratios[f"{path}_vs_copy"] == pytest.approx(s[path] / s["copy"])
        assert ratios["gs_tf_vs_numpy"] == pytest.approx(s["numpy"] / s["gs_tf_frame"])
        assert ratios["checksum_share"] == pytest.approx(s["checksum"] / s["compute_frame"])
        for engine in ("gs_tf", "compute"):
            assert ratios[f"{engine}_portable_cost"] == pytest.approx(
                s[f"{engine}_portable_frame"] / s[f"{engine}_frame"])
        for path, seconds in s.items():
            assert size["particles_per_s"][path] == pytest.approx(size["particles"] / seconds)


def test_every_target_is_judged_at_the_largest_size_when_its_own_is_missing(bench_run):
    _, _, report = bench_run
    assert [t["name"] for t in report["targets"]] == [t.ratio for t in TARGETS]
    largest = report["sizes"][-1]
    for target in report["targets"]:
        assert target["particles"] == max(SIZES)
        assert target["measured"] == largest["ratios"][target["name"]]
        bound, measured = target["target"], target["measured"]
        assert target["met"] == (measured >= bound if target["comparison"] == ">="
                                 else measured <= bound)


def test_markdown_has_the_table_and_targets(bench_run):
    _, out, _ = bench_run
    text = (out / "bench.md").read_text()
    assert ("| particles | GS/TF frame ms | compute frame ms | compute speedup | portable GS/TF "
            "frame ms | portable compute frame ms | portable cost |") in text
    assert "| 2,000 |" in text and "| 5,000 |" in text
    assert all(t.ratio in text for t in TARGETS)


def figures(particles: int, compute_frame_s: float = 0.5) -> SizeFigures:
    return SizeFigures(particles, gs_tf_frame_s=2.0, compute_frame_s=compute_frame_s,
                       gs_tf_portable_frame_s=2.2, compute_portable_frame_s=0.6,
                       gs_tf_update_s=1.5, compute_update_s=0.3, checksum_s=0.05, copy_s=0.1,
                       numpy_s=30.0, gpu_frames=2, numpy_frames=2, live_after=particles)


def test_each_target_is_judged_at_its_own_size_when_measured():
    judged = evaluate_targets([figures(1_000_000), figures(3_000_000),
                               figures(10_000_000, compute_frame_s=0.25)])
    assert [(t["name"], t["particles"]) for t in judged] == [
        ("compute_speedup", 1_000_000), ("compute_frame_vs_copy", 10_000_000),
        ("gs_tf_vs_numpy", 1_000_000), ("checksum_share", 1_000_000)]
    assert [t["met"] for t in judged] == [True, True, True, True]  # 4x, 2.5x, 15x, 10 %
    assert {t["renderer"] for t in judged} == {"llvmpipe", "GPU"}


def test_default_sizes_are_1m_10m_and_the_largest_naming_what_does_not_fit(ctx):
    limits = capacity_limits(ctx.info)
    sizes, skipped = default_sizes(limits)
    largest = limits.max_capacity
    assert sizes == sorted({n for n in DEFAULT_SIZES if n <= largest} | {largest})
    assert [s["particles"] for s in skipped] == [n for n in DEFAULT_SIZES if n > largest]
    for skip in skipped:
        assert f"{largest:,}" in skip["why"] and limits.binding.name in skip["why"]


@pytest.mark.parametrize("argv, flag", [
    (["--sizes", "0"], "--sizes"),
    (["--sizes", "abc"], "--sizes"),
    (["--sizes", f"1000,{MAX_PARTICLES + 1}"], "--sizes"),
    (["--frames", "0"], "--frames"),
    (["--scene", "/nonexistent.toml"], "--scene"),
])
def test_bad_flags_exit_2_with_one_line_naming_the_flag(capsys, tmp_path, argv, flag):
    assert main(["bench", *argv, "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and flag in err and repr(argv[1]) in err
    assert not any(tmp_path.iterdir())


def test_an_out_path_that_is_a_file_exits_2(capsys, tmp_path):
    taken = tmp_path / "bench.json"
    taken.write_text("{}")
    assert main(["bench", "--out", str(taken)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--out" in err and repr(str(taken)) in err


@pytest.mark.parametrize("command", [["bench", "--sizes"], ["accuracy", "--particles"]],
                         ids=["bench", "accuracy"])
def test_a_size_beyond_the_context_fails_in_one_line_before_measuring(ctx, tmp_path, command):
    """Beyond the driver's bound: exit 1 naming the binding limit and the driver, and
    nothing measured or written. Where the driver's bound is the engine's own (an H100's 2 GiB
    storage block holds exactly MAX_PARTICLES records), the flag's parser refuses it: exit 2."""
    limits = capacity_limits(ctx.info)
    size = limits.max_capacity + 1
    sizes = f"1000,{size}" if command[0] == "bench" else str(size)
    done = subprocess.run([sys.executable, "-c", RUN_MAIN, *command, sizes, "--out",
                           str(tmp_path / "out")], capture_output=True, text=True, timeout=120)
    assert done.stderr.count("\n") == 1 and "measured" not in done.stdout
    assert not list(tmp_path.rglob("*.json"))
    if size > MAX_PARTICLES:
        assert done.returncode == 2 and f"1..{MAX_PARTICLES}," in done.stderr
        return
    assert done.returncode == 1, done.stderr
    assert done.stderr.startswith("cavesim: error: capacity ")
    assert f"{limits.binding.name} = {limits.binding.value}" in done.stderr
    assert ctx.info["GL_RENDERER"] in done.stderr


def test_a_helicopter_scene_is_measured_with_its_rotor_flying_its_timeline(ctx):
    """The brownout demo steps with a rotor frame every frame, as a node decodes it."""
    scene = load_scene(REPO_ROOT / "config/scenes/brownout.toml")
    frames = frame_inputs(scene, 3)
    assert all(state.rotor is not None and len(state.rotor.emission_factors) ==
               len(scene.emitters) for _, state in frames)
    figures = measure_size(ctx, scene, 2000, 1, lambda path: None)
    assert figures.live_after == 2000
    assert figures.compute_portable_cost > 0 and figures.gs_tf_portable_cost > 0
