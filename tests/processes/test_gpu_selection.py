"""Choosing a wall's GPU: spreading walls over EGL devices, `cavesim node --gpu`, the CAVE
file's `gpu` key, and the GPU each wall names in `cavesim run`'s report."""

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from cavesim.core.errors import ContextError
from cavesim.gpu.gl.devices import EglDevice, list_devices
from nodes.cli import main
from nodes.commands.run import RunPlan
from nodes.launch.gpus import by_gpu, spread_walls

TWO_NODES = {"front": ("front",), "left": ("left",)}  # a plan's nodes and their walls

ROOT = Path(__file__).parents[2]
MINIMAL = ROOT / "config" / "scenes" / "minimal.toml"
WALLS = ("front", "left", "right", "floor")
SOFTWARE = ("EGL_MESA_device_software",)


def gpu(index: int) -> EglDevice:
    return EglDevice(index, ("EGL_EXT_device_drm",), drm_file=f"/dev/dri/card{index}")


def llvmpipe(index: int) -> EglDevice:
    return EglDevice(index, SOFTWARE)


def test_without_a_gpu_no_wall_is_given_a_device():
    assert spread_walls(WALLS, {}, [llvmpipe(0)]) == {}
    assert spread_walls(WALLS, {}, []) == {}


def test_walls_go_round_robin_over_the_hardware_devices_only():
    devices = [gpu(0), gpu(1), llvmpipe(2)]
    assert spread_walls(WALLS, {}, devices) == {"front": 0, "left": 1, "right": 0, "floor": 1}
    devices = [llvmpipe(0), gpu(1), gpu(2), gpu(3)]
    assert spread_walls(WALLS, {}, devices) == {"front": 1, "left": 2, "right": 3, "floor": 1}


def test_a_pinned_wall_keeps_its_device_and_counts_toward_its_load():
    devices = [gpu(0), gpu(1)]
    chosen = spread_walls(WALLS, {"front": 0}, devices)
    assert chosen == {"front": 0, "left": 1, "right": 0, "floor": 1}
    assert spread_walls(WALLS, {"left": 0, "right": 0}, devices) == {
        "front": 1, "left": 0, "right": 0, "floor": 1}
    # pinning to the software device is the administrator's call
    assert spread_walls(("front",), {"front": 1}, [gpu(0), llvmpipe(1)]) == {"front": 1}
    assert spread_walls(WALLS, {"floor": 0}, [llvmpipe(0)]) == {"floor": 0}


def test_grouping_by_gpu_makes_one_node_per_device_with_its_walls():
    chosen = spread_walls(WALLS, {}, [gpu(0), gpu(1)])
    assert by_gpu(WALLS, chosen) == ({"gpu0": ("front", "right"), "gpu1": ("left", "floor")},
                                     {"gpu0": 0, "gpu1": 1})
    assert by_gpu(WALLS, {}) == ({"gpu0": WALLS}, {})  # no hardware: the default device


def test_a_wall_pinned_past_the_devices_is_named_with_the_count():
    with pytest.raises(ContextError) as error:
        spread_walls(WALLS, {"left": 2}, [gpu(0), llvmpipe(1)])
    assert str(error.value) == ("wall 'left': EGL device 2 does not exist: this machine has 2 "
                                "EGL device(s) (device 0 is hardware, device 1 is software); "
                                "`cavesim doctor` lists the EGL devices")


def test_each_node_gets_its_own_gpu_flag_and_the_drawing_flags():
    plan = RunPlan(TWO_NODES, MINIMAL, 5, Path("out"), gpus={"left": 1})
    assert plan.node_args("front") == () and plan.node_args("left") == ("--gpu", "1")
    drawn = RunPlan(TWO_NODES, MINIMAL, 5, Path("out"), cave=Path("c.toml"),
                    render_every=5, gpus={"front": 0})
    assert drawn.node_args("front")[-2:] == ("--gpu", "0")
    assert "--gpu" not in drawn.node_args("left") and "--cave" in drawn.node_args("left")
    grouped = RunPlan({"ws1": ("front", "left")}, MINIMAL, 5, Path("out"), cave=Path("c.toml"),
                      render_every=5, gpus={"ws1": 1})
    args = grouped.node_args("ws1")
    assert args[args.index("--draws") + 1] == "front,left" and args[-2:] == ("--gpu", "1")


@pytest.mark.parametrize("value", ["-1", "256", "1.5", "first", ""])
def test_node_gpu_flag_is_checked_at_the_edge(capsys, value):
    assert main(["node", "--wall", "front", "--gpu", value]) == 2
    error = capsys.readouterr().err
    assert error == (f"cavesim node: error: argument --gpu: expected an EGL device index in "
                     f"[0, 255], got {value!r}\n")


def test_a_node_on_a_device_that_does_not_exist_says_so_in_one_line(tmp_path):
    missing = len(list_devices())
    result = subprocess.run(
        [sys.executable, "-m", "cavesim", "node", "--wall", "front", "--gpu", str(missing),
         "--scene", str(MINIMAL), "--listen", "tcp/127.0.0.1:0", "--session",
         f"nogpu{os.getpid()}"], capture_output=True, text=True, timeout=60, cwd=tmp_path)
    assert result.returncode == 1
    assert result.stderr.startswith(f"cavesim: error: cannot open a headless OpenGL context: "
                                    f"EGL device {missing} does not exist: ")
    assert "`cavesim doctor`" in result.stderr and result.stderr.count("\n") == 1


CAVE = """
[[wall]]
name = "front"
lower_left = [-1.5, 1.5, 0.0]
lower_right = [1.5, 1.5, 0.0]
upper_left = [-1.5, 1.5, 3.0]
resolution = [32, 32]
gpu = {gpu}
[[wall]]
name = "left"
lower_left = [-1.5, -1.5, 0.0]
lower_right = [-1.5, 1.5, 0.0]
upper_left = [-1.5, -1.5, 3.0]
resolution = [32, 32]
"""


def test_run_refuses_a_cave_that_pins_a_missing_device(tmp_path, capsys):
    cave = tmp_path / "cave.toml"
    cave.write_text(CAVE.format(gpu=200))
    assert main(["run", "--cave", str(cave), "--out", str(tmp_path / "out")]) == 2
    error = capsys.readouterr().err
    assert error.startswith(f"cavesim run: error: argument --cave: {cave}: wall 'front': EGL "
                            f"device 200 does not exist: this machine has ")
    assert not (tmp_path / "out").exists()


@pytest.mark.slow
def test_run_reports_the_gpu_of_every_wall(tmp_path):
    """A pinned wall and a chosen one, through the nodes' info answers to the report."""
    cave = tmp_path / "cave.toml"
    cave.write_text(CAVE.format(gpu=0))
    out = tmp_path / "out"
    command = [sys.executable, "-m", "cavesim", "run", "--cave", str(cave), "--frames", "5",
               "--render-every", "0", "--scene", str(MINIMAL), "--engine", "compute", "--out",
               str(out), "--session", f"gpus{os.getpid()}"]
    result = subprocess.run(command, capture_output=True, text=True, timeout=180, cwd=ROOT)
    assert result.returncode == 0, result.stdout + result.stderr
    report = json.loads((out / "report.json").read_text())
    device = list_devices()[0]
    for wall in ("front", "left"):
        described = report["gpus"][wall]
        assert described["device"] == 0 and described["kind"] == device.kind
        assert described["renderer"] and described["vendor"] and described["version"]
        assert described["engine"] == "compute"  # the path the node ran, as it said
        log = (out / "logs" / f"{wall}.log").read_text()
        assert f"{wall}: up on EGL device 0 ({device.kind}): {described['renderer']}" in log
    assert "GPUs" in result.stdout and described["renderer"] in result.stdout


def test_engine_auto_probes_on_every_node_and_the_run_steps_with_one_path(tmp_path):
    out = tmp_path / "out"
    command = [sys.executable, "-m", "cavesim", "run", "--walls", "3", "--frames", "10",
               "--scene", str(MINIMAL), "--engine", "auto", "--out", str(out), "--session",
               f"auto{os.getpid()}"]
    result = subprocess.run(command, capture_output=True, text=True, timeout=180, cwd=ROOT)
    assert result.returncode == 0, result.stdout + result.stderr
    report = json.loads((out / "report.json").read_text())
    paths = {report["gpus"][node]["engine"] for node in report["nodes"]}
    assert len(paths) == 1 and paths <= {"gs_tf", "compute"}
    assert all(report["gpus"][node]["engine_probed"] for node in report["nodes"])
    (path,) = paths
    for node in report["nodes"]:
        log = (out / "logs" / f"{node}.log").read_text()
        probed = re.search(r"engine auto: gs_tf [\d.]+ ms, compute [\d.]+ ms a frame of "
                           r"10,000 particles: (\w+)", log)
        assert probed is not None, log
        assert (probed.group(1) != path) == (f"the run steps with {path}" in log)
    assert f"{path} (probed)" in result.stdout
