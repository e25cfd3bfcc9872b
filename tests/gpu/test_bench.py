"""`cavesim bench`: the reports it writes, the figures in them, its lines as it goes, how a
stopped run ends, and its answer to bad flags.

The benchmark runs `nodes.cli.main` in a child process: it opens its own EGL context, and
a second context in the test process would become current in place of `gl_session`; tests in
this process hand `run_bench` the session's context.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
from types import SimpleNamespace

import pytest
from rich.console import Console

from cavesim.core.limits import MAX_PARTICLES
from cavesim.core.scene import load_scene
from cavesim.gpu.engine.capacity import Bound, CapacityLimits, capacity_limits
from cavesim.tools.bench import TARGETS, SizeFigures, runner
from cavesim.tools.bench import measure as bench_measure
from cavesim.tools.bench.figures import PATHS, RATIOS, evaluate_targets
from cavesim.tools.bench.measure import (
    MIN_TIMED_FRAMES,
    NUMPY_UP_TO,
    PATH_BUDGET_S,
    BenchPlan,
    measure_size,
    time_frames,
)
from cavesim.tools.bench.report import target_line
from cavesim.tools.bench.runner import DEFAULT_SIZES, QUICK_SIZES, default_sizes, run_bench
from cavesim.tools.bench.workload import frame_inputs
from nodes.arguments import REPO_ROOT
from nodes.cli import build_parser, main
from nodes.commands.bench import QUICK_FRAMES
from nodes.run_folder import LOCK, MARKER

SIZES = (2000, 5000)
NUMPY_CAP = 3000  # the numpy twin is timed at the first size, not at the second
RUN_MAIN = "import sys; from nodes.cli import main; sys.exit(main(sys.argv[1:]))"
MEASURED_ORDER = ("gs_tf_frame", "checksum", "gs_tf_update", "compute_frame", "compute_update",
                  "gs_tf_portable_frame", "compute_portable_frame", "copy", "numpy")
pytestmark = pytest.mark.xdist_group("bench")  # one bench run, on one worker


@pytest.fixture(scope="module")
def bench_run(tmp_path_factory):
    """One small benchmark run from a directory outside the repository (default scene)."""
    work = tmp_path_factory.mktemp("bench")
    out = work / "reports"
    argv = ["bench", "--sizes", ",".join(map(str, SIZES)), "--frames", "2", "--numpy-up-to",
            str(NUMPY_CAP), "--out", str(out)]
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


def test_prints_a_plain_line_per_size_and_path_before_the_table(bench_run):
    """A pipe sees them: no progress bar, no markup."""
    done, _, _ = bench_run
    lines = done.stdout.splitlines()
    table = next(k for k, line in enumerate(lines) if "speedup" in line)
    path_lines = [line.split() for line in lines[:table] if "[" in line and " ms " in line
                  or "not timed" in line]
    assert [(words[0], words[1]) for words in path_lines] == [
        (f"{size:,}", path) for size in SIZES for path in MEASURED_ORDER]
    assert " ".join(path_lines[-1][2:6]) == f"not timed (above {NUMPY_CAP:,})"
    assert path_lines[0][3:9] == ["ms", path_lines[0][4], "M", "particles/s", "2", "frames"]


def test_json_has_every_size_with_positive_finite_figures(bench_run):
    _, _, report = bench_run
    assert report["command"] == "bench" and report["scene"]["name"] == "bench"
    assert report["ended"] == "complete"
    assert report["frames"] == 2 and report["gl"]["renderer"]
    assert report["numpy_up_to"] == NUMPY_CAP
    assert [size["particles"] for size in report["sizes"]] == list(SIZES)
    assert report["skipped_sizes"] == []
    for size in report["sizes"]:
        assert set(size["seconds"]) == set(PATHS) and set(size["ratios"]) == set(RATIOS)
        assert set(size["frames"]) == set(PATHS)
        figures = [*size["seconds"].values(), *size["particles_per_s"].values(),
                   *size["ratios"].values()]
        if size["particles"] > NUMPY_CAP:  # named, not timed
            assert size["not_timed"] == {"numpy": "above numpy_up_to, 3,000 particles"}
            assert size["seconds"]["numpy"] is None and size["frames"]["numpy"] == 0
            figures = [x for x in figures if x is not None]
            assert len(figures) == 3 * len(PATHS) - 3
        assert all(math.isfinite(x) and x > 0 for x in figures), size
        assert size["live_after"] == size["particles"]


def test_ratios_and_rates_follow_from_the_times(bench_run):
    _, _, report = bench_run
    for size in report["sizes"]:
        s, ratios = size["seconds"], size["ratios"]
        assert ratios["compute_speedup"] == pytest.approx(s["gs_tf_frame"] / s["compute_frame"])
        for path in ("gs_tf_frame", "compute_frame", "gs_tf_update", "compute_update"):
            assert ratios[f"{path}_vs_copy"] == pytest.approx(s[path] / s["copy"])
        if s["numpy"] is not None:
            assert ratios["gs_tf_vs_numpy"] == pytest.approx(s["numpy"] / s["gs_tf_frame"])
        assert ratios["checksum_share"] == pytest.approx(s["checksum"] / s["compute_frame"])
        for engine in ("gs_tf", "compute"):
            assert ratios[f"{engine}_portable_cost"] == pytest.approx(
                s[f"{engine}_portable_frame"] / s[f"{engine}_frame"])
        for path, seconds in s.items():
            if seconds is not None:
                assert size["particles_per_s"][path] == pytest.approx(size["particles"] / seconds)


def test_every_target_is_judged_at_the_largest_size_that_measured_it(bench_run):
    """None of the targets' own sizes is measured; the numpy twin only at the first size."""
    _, _, report = bench_run
    assert [t["name"] for t in report["targets"]] == [t.ratio for t in TARGETS]
    for target in report["targets"]:
        judged = min(SIZES) if target["name"] == "gs_tf_vs_numpy" else max(SIZES)
        assert target["particles"] == judged
        size = next(size for size in report["sizes"] if size["particles"] == judged)
        assert target["measured"] == size["ratios"][target["name"]]
        bound, measured = target["target"], target["measured"]
        software = "llvmpipe" in report["gl"]["renderer"]  # the renderer the bench ran on
        assert target["applies"] == ((target["renderer"] == "llvmpipe") == software)
        met = measured >= bound if target["comparison"] == ">=" else measured <= bound
        assert target["met"] == (met if target["applies"] else None)


def test_markdown_has_the_table_and_targets(bench_run):
    _, out, _ = bench_run
    text = (out / "bench.md").read_text()
    assert ("| particles | GS/TF frame ms | compute frame ms | compute speedup | portable GS/TF "
            "frame ms | portable compute frame ms | portable cost |") in text
    assert "| 2,000 |" in text and "| 5,000 |" in text
    assert "| not timed (above 3,000) | not timed (above 3,000) |" in text
    assert all(t.ratio in text for t in TARGETS)


def figures(particles: int, compute_frame_s: float = 0.5,
            numpy_s: float | None = 30.0) -> SizeFigures:
    return SizeFigures(particles, gs_tf_frame_s=2.0, compute_frame_s=compute_frame_s,
                       gs_tf_portable_frame_s=2.2, compute_portable_frame_s=0.6,
                       gs_tf_update_s=1.5, compute_update_s=0.3, checksum_s=0.05, copy_s=0.1,
                       numpy_s=numpy_s, frames=dict.fromkeys(PATHS, 2), live_after=particles)


def test_each_target_is_judged_at_its_own_size_on_the_renderer_it_is_meant_for():
    sizes = [figures(1_000_000), figures(3_000_000), figures(10_000_000, compute_frame_s=0.25)]
    on_llvmpipe, on_a_gpu = evaluate_targets(sizes, True), evaluate_targets(sizes, False)
    assert [(t["name"], t["particles"]) for t in on_llvmpipe] == [
        ("compute_speedup", 1_000_000), ("compute_frame_vs_copy", 10_000_000),
        ("gs_tf_vs_numpy", 1_000_000), ("checksum_share", 1_000_000)]
    assert [t["renderer"] for t in on_llvmpipe] == ["llvmpipe", "GPU", "llvmpipe", "llvmpipe"]
    assert [t["met"] for t in on_llvmpipe] == [True, None, True, True]  # 4x, -, 15x, 10 %
    assert [t["met"] for t in on_a_gpu] == [None, True, None, None]  # 2.5x
    assert target_line(on_llvmpipe[1]) == (
        "compute_frame_vs_copy <= 3 at 10,000,000 particles (GPU target): measured 2.50x - "
        "not judged: a GPU target, and this renderer is not one")


def test_a_ratio_the_numpy_twin_did_not_time_is_judged_where_it_did_or_named_unmeasured():
    timed_below = {t["name"]: t for t in evaluate_targets(
        [figures(500_000), figures(1_000_000, numpy_s=None)], True)}
    assert timed_below["gs_tf_vs_numpy"]["particles"] == 500_000
    assert timed_below["compute_speedup"]["particles"] == 1_000_000
    for sizes in ([figures(10_000_000, numpy_s=None)], []):
        numpy = next(t for t in evaluate_targets(sizes, True) if t["name"] == "gs_tf_vs_numpy")
        assert (numpy["measured"], numpy["met"], numpy["particles"]) == (None, None, None)
        assert target_line(numpy) == ("gs_tf_vs_numpy >= 10 (llvmpipe target): not measured "
                                      "at any size")
    assert figures(10_000_000, numpy_s=None).to_json()["particles_per_s"]["numpy"] is None


def test_default_sizes_are_1m_10m_and_the_largest_naming_what_does_not_fit(ctx):
    limits = capacity_limits(ctx.info)
    sizes, skipped = default_sizes(limits)
    largest = limits.max_capacity
    assert sizes == sorted({n for n in DEFAULT_SIZES if n <= largest} | {largest})
    assert [s["particles"] for s in skipped] == [n for n in DEFAULT_SIZES if n > largest]
    for skip in skipped:
        assert f"{largest:,}" in skip["why"] and limits.binding.name in skip["why"]


def test_quick_sizes_are_two_small_ones_capped_by_the_context(ctx):
    limits = capacity_limits(ctx.info)
    sizes, skipped = default_sizes(limits, quick=True)
    assert sizes == sorted({min(n, limits.max_capacity) for n in QUICK_SIZES}) and not skipped
    assert len(sizes) <= 2 and max(sizes) <= 1_000_000
    small = CapacityLimits((Bound("GL_MAX_SHADER_STORAGE_BLOCK_SIZE", 16_000_000, "bytes",
                                  "the checksum's block", 400_000),), "a small driver")
    assert default_sizes(small, quick=True) == ([100_000, 400_000], [])


def test_quick_parses_and_its_help_names_what_it_measures(capsys):
    args = build_parser().parse_args(["bench", "--quick"])
    assert args.quick and args.sizes is None and args.frames is None
    with pytest.raises(SystemExit):
        main(["bench", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "--quick a one-minute answer" in text and f"{QUICK_FRAMES} timed frames" in text
    assert all(str(n) in text for n in QUICK_SIZES)
    assert f"(at least {MIN_TIMED_FRAMES}) once a path's took {PATH_BUDGET_S:g} s" in text
    assert f"(default: {NUMPY_UP_TO}; 0: never)" in text


@pytest.mark.parametrize("flag, value, other", [
    ("--quick", [], ["--sizes", "1000"]), ("--quick", [], ["--cluster"]),
    ("--quick", [], ["--resync"]), ("--quick", [], ["--soak"]),
    ("--numpy-up-to", ["5"], ["--soak"])])
def test_engine_bench_flags_with_another_mode_exit_2_in_one_line(capsys, tmp_path, flag, value,
                                                                 other):
    assert main(["bench", flag, *value, *other, "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"argument {flag}: not with {other[0]}" in err
    assert not any(tmp_path.iterdir())


@pytest.mark.parametrize("seconds_a_frame, frames, timed", [
    (0.01, 10, 10),  # fast: every frame asked for
    (0.6, 10, 4),  # 2.4 s: the budget of 2 s is spent after four frames
    (5.0, 10, MIN_TIMED_FRAMES),  # slow: the least a median is taken of
    (5.0, 2, 2),  # fewer asked for than that least
])
def test_a_path_whose_frames_are_slow_times_fewer_of_them(monkeypatch, seconds_a_frame, frames,
                                                           timed):
    now = [0.0]
    monkeypatch.setattr(bench_measure, "time", SimpleNamespace(perf_counter=lambda: now[0]))
    calls = []

    def frame() -> None:
        calls.append(now[0])
        now[0] += seconds_a_frame

    timing = time_frames(frame, 2, frames, budget_s=2.0)
    assert timing.frames == timed and len(calls) == 2 + timed
    assert timing.seconds == pytest.approx(seconds_a_frame)


def test_each_path_is_printed_and_each_size_written_as_it_is_measured(ctx, tmp_path,
                                                                      monkeypatch):
    """The console's lines, the start of each size's measuring and each write of the reports,
    in the order they happened; with no time to spare, every path times its least frames."""
    events = []

    class Log:  # the console's file
        def write(self, text: str) -> None:
            events.extend(("line", *line.split()[:2]) for line in text.splitlines())

        def flush(self) -> None:
            pass

    measure, write = runner.measure_size, runner.write_reports

    def measuring(ctx, scene, count, plan, measured):
        events.append(("measure", count))
        return measure(ctx, scene, count, plan, measured)

    def writing(report, sizes, out_dir):
        events.append(("write", report["ended"], len(report["sizes"])))
        return write(report, sizes, out_dir)

    monkeypatch.setattr(runner, "measure_size", measuring)
    monkeypatch.setattr(runner, "write_reports", writing)
    scene = load_scene(REPO_ROOT / "config/scenes/bench.toml")
    plan = BenchPlan(frames=5, numpy_up_to=1000, path_budget_s=0.0)
    report = run_bench(scene, [1000, 2000], plan, tmp_path, Console(file=Log(), width=120),
                       ctx=ctx)
    path_lines = {("line", f"{count:,}", path) for count in (1000, 2000) for path in PATHS}
    expected = []
    for k, count in enumerate((1000, 2000), start=1):
        expected += [("measure", count),
                     *(("line", f"{count:,}", path) for path in MEASURED_ORDER),
                     ("write", "running", k)]
    assert [event for event in events if event[0] != "line" or event in path_lines] == [
        *expected, ("write", "complete", 2)]
    assert report["ended"] == "complete"
    for size, numpy_frames in zip(report["sizes"], (2, 0), strict=True):  # numpy_frames(5): 2
        assert size["frames"] == {**dict.fromkeys(PATHS, MIN_TIMED_FRAMES), "numpy": numpy_frames}


STOPPING_MAIN = """
import os, signal, sys
from cavesim.tools.bench import runner
from cavesim.tools.bench.measure import BenchError
from nodes.cli import main

measure_size = runner.measure_size

def stop_at_the_second_size(ctx, scene, count, plan, measured):
    if count == 2000:
        {stop}
    return measure_size(ctx, scene, count, plan, measured)

runner.measure_size = stop_at_the_second_size
sys.exit(main(sys.argv[1:]))
"""


@pytest.mark.parametrize("stop, code, ended", [
    ("raise KeyboardInterrupt", 130, "interrupted"),
    ("os.kill(os.getpid(), signal.SIGTERM)", 130, "interrupted"),
    ("raise BenchError('GL reported GL_INVALID_OPERATION')", 1,
     "GL reported GL_INVALID_OPERATION"),
], ids=["ctrl-c", "sigterm", "error"])
def test_a_run_stopped_in_its_second_size_leaves_the_first_written(tmp_path, stop, code, ended):
    out = tmp_path / "out"
    done = subprocess.run([sys.executable, "-c", STOPPING_MAIN.format(stop=stop), "bench",
                           "--sizes", "1000,2000", "--frames", "1", "--out", str(out)],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == code, done.stderr
    assert done.stderr.count("\n") == 1 and "Traceback" not in done.stderr
    if code == 130:
        assert done.stderr == f"cavesim bench: interrupted; 1 finished size in {out}/bench.json\n"
    assert done.stdout.count("       1,000  ") == len(PATHS)
    report = json.loads((out / "bench.json").read_text())
    assert report["ended"] == ended and [s["particles"] for s in report["sizes"]] == [1000]
    assert all(t["particles"] == 1000 for t in report["targets"])
    assert "| 1,000 |" in (out / "bench.md").read_text()
    assert sorted(p.name for p in out.iterdir()) == [MARKER, LOCK, "bench.json", "bench.md"]


@pytest.mark.parametrize("argv, flag", [
    (["--sizes", "0"], "--sizes"),
    (["--sizes", "abc"], "--sizes"),
    (["--sizes", f"1000,{MAX_PARTICLES + 1}"], "--sizes"),
    (["--frames", "0"], "--frames"),
    (["--numpy-up-to", "-1"], "--numpy-up-to"),
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
    figures = measure_size(ctx, scene, 2000, BenchPlan(1), lambda path, timing: None)
    assert figures.live_after == 2000
    assert figures.compute_portable_cost > 0 and figures.gs_tf_portable_cost > 0
