"""`cavesim doctor`: the verdict from findings, the checks one by one, and the command end
to end on this machine (usable) and without an EGL driver (not usable: reason and fix)."""

import json
import os
import socket
import subprocess
import sys
import types
from importlib import metadata
from pathlib import Path

import pytest
import zenoh

from cavesim.core.records import PARTICLE_BYTES
from cavesim.core.wire.network import NetworkSettings, zenoh_config
from cavesim.gpu.gl.devices import list_devices
from cavesim.tools.doctor import probe as probing
from cavesim.tools.doctor.checks import check_windows, check_zenoh
from cavesim.tools.doctor.verdict import judge

ROOT = Path(__file__).resolve().parents[2]
DEVICE = {"index": 0, "kind": "software", "usable": True, "opened": True,
          "renderer": "llvmpipe", "largest_capacity": 3_355_443, "state_bytes": 134_217_720,
          "problem": None, "fix": None}
GPU = {**DEVICE, "index": 1, "kind": "hardware", "renderer": "NVIDIA H100",
       "largest_capacity": 53_687_091, "state_bytes": 2_147_483_640}
ZENOH = {"opened": True, "error": None, "connect": [], "peers": [], "routers": []}
WINDOWS = {"can_open": True, "reason": None}


def findings(devices=(DEVICE,), egl=None, zenoh_found=ZENOH, windows=WINDOWS) -> dict:
    return {"egl": egl or {}, "devices": list(devices), "zenoh": zenoh_found,
            "windows": windows}


# -- the verdict ---------------------------------------------------------------------------

def test_a_usable_device_and_a_session_make_a_node_that_can_run():
    verdict = judge(findings([DEVICE, GPU]))
    assert verdict.ok and verdict.fix == "" and verdict.warnings == ()
    assert "0 (software, llvmpipe), 1 (hardware, NVIDIA H100)" in verdict.reason
    assert "up to 53,687,091 particles per wall on device 1 (2.00 GiB per particle buffer)" \
        in verdict.reason
    assert (verdict.largest_capacity, verdict.state_bytes) == (53_687_091, 2_147_483_640)


def test_no_egl_names_the_problem_and_its_fix():
    verdict = judge(findings([], egl={"problem": "cannot load libEGL.so.1", "fix": "apt"}))
    assert not verdict.ok and (verdict.reason, verdict.fix) == ("cannot load libEGL.so.1", "apt")
    verdict = judge(findings([]))
    assert not verdict.ok and "no EGL device" in verdict.reason and "libegl1" in verdict.fix


def test_no_usable_device_names_each_device_and_the_first_fix():
    old = {**DEVICE, "usable": False, "problem": "OpenGL 4.3 core is required", "fix": "Mesa"}
    dead = {**GPU, "usable": False, "opened": False, "problem": "its probe ended with signal 11",
            "fix": "driver"}
    verdict = judge(findings([old, dead]))
    assert not verdict.ok and verdict.fix == "Mesa" and "\n" not in verdict.reason
    assert verdict.reason == ("no EGL device can run cavesim: device 0 (software): OpenGL 4.3 "
                              "core is required; device 1 (hardware): its probe ended with "
                              "signal 11")


def test_a_session_that_does_not_open_fails_with_the_flags_to_check():
    verdict = judge(findings(zenoh_found={**ZENOH, "opened": False, "error": "port in use"}))
    assert not verdict.ok and verdict.reason.endswith("port in use")
    assert "--listen" in verdict.fix


def test_what_works_but_may_surprise_is_a_warning():
    broken = {**DEVICE, "usable": False, "problem": "no compute shaders"}
    verdict = judge(findings(
        [broken, GPU], zenoh_found={**ZENOH, "connect": ["tcp/10.0.0.1:7447"]},
        windows={"can_open": False, "reason": "the glfw package is not installed"}))
    assert verdict.ok and "device(s) 1 (hardware" in verdict.reason
    assert verdict.warnings == (
        "EGL device 0 (software) cannot run cavesim: no compute shaders",
        "the default EGL device 0 cannot run cavesim: give nodes --gpu 1 (or `gpu` in the "
        "CAVE file)",
        "no zenoh peer or router answered at tcp/10.0.0.1:7447 (is the master up?)",
        "windows cannot open: the glfw package is not installed (optional: walls render to "
        "files)")


# -- the checks ----------------------------------------------------------------------------

def test_a_device_past_the_count_is_a_finding_not_a_crash():
    missing = len(list_devices())
    found = probing.probe(missing)
    assert found["usable"] is False and found["opened"] is False
    assert found["problem"].startswith(f"cannot open a headless OpenGL context: EGL device "
                                       f"{missing} does not exist")


def test_a_probe_that_crashes_or_hangs_is_named(monkeypatch):
    def crashed(command, **kwargs):
        return subprocess.CompletedProcess(command, -11, "", "Fatal Python error\nSegfault\n")

    monkeypatch.setattr(probing.subprocess, "run", crashed)
    assert probing.probe(0)["problem"] == "its probe ended with signal 11: Segfault"

    def hung(command, timeout, **kwargs):
        raise subprocess.TimeoutExpired(command, timeout)

    monkeypatch.setattr(probing.subprocess, "run", hung)
    assert probing.probe(0, timeout=3)["problem"].startswith("its probe did not finish within 3")


def test_the_session_check_reports_a_port_in_use_in_one_line():
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        endpoint = f"tcp/127.0.0.1:{taken.getsockname()[1]}"
        found = check_zenoh(NetworkSettings(listen=(endpoint,)))
    assert not found["opened"] and found["listen"] == [endpoint]
    assert "Address already in use" in found["error"]
    assert ".rs:" not in found["error"] and "\n" not in found["error"]


def test_the_session_check_reaches_a_peer_it_is_told_to_connect_to():
    with socket.socket() as probe_port:
        probe_port.bind(("127.0.0.1", 0))
        endpoint = f"tcp/127.0.0.1:{probe_port.getsockname()[1]}"
    with zenoh.open(zenoh_config(NetworkSettings(listen=(endpoint,)))) as peer:
        found = check_zenoh(NetworkSettings(connect=(endpoint,)))
        assert found["opened"] and found["peers"] == [str(peer.info.zid())]
    assert found["version"] == metadata.version("eclipse-zenoh") and found["mode"] == "peer"


def fake_glfw(starts: bool) -> types.ModuleType:
    module = types.ModuleType("glfw")
    module.__version__ = "2.11.0"
    module.GLFWError = type("GLFWError", (Exception,), {})
    calls = {}

    def init():
        if not starts:
            calls["callback"](65550, b"X11: The DISPLAY environment variable is missing")
        return starts

    module.set_error_callback = lambda callback: calls.update(callback=callback)
    module.init = init
    module.terminate = lambda: calls.update(terminated=True)
    module.calls = calls
    return module


def test_windows_are_reported_with_or_without_glfw(monkeypatch):
    monkeypatch.setitem(sys.modules, "glfw", None)  # import glfw raises ImportError
    found = check_windows()
    assert not found["can_open"] and "glfw package is not installed" in found["reason"]
    monkeypatch.setitem(sys.modules, "glfw", fake_glfw(starts=False))
    found = check_windows()
    assert not found["can_open"] and found["glfw"] == "2.11.0"
    assert found["reason"] == "glfw.init() failed: X11: The DISPLAY environment variable is missing"
    glfw = fake_glfw(starts=True)
    monkeypatch.setitem(sys.modules, "glfw", glfw)
    assert check_windows()["can_open"] and glfw.calls["terminated"]


# -- the command ---------------------------------------------------------------------------

def doctor(tmp_path, *args, env=None) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "cavesim", "doctor", "--out",
                           str(tmp_path / "doctor.json"), *args], capture_output=True,
                          text=True, timeout=180, env={**os.environ, **(env or {})})


def test_doctor_passes_here_and_writes_what_it_found(tmp_path):
    result = doctor(tmp_path, "--listen", "tcp/127.0.0.1:0")
    assert result.returncode == 0, result.stdout + result.stderr
    found = json.loads((tmp_path / "doctor.json").read_text())
    device = found["devices"][0]
    assert device["index"] == 0 and device["kind"] == list_devices()[0].kind
    assert device["usable"] and device["smoke"]["ok"] and device["version"].startswith("4.")
    limit = device["limits"]["GL_MAX_SHADER_STORAGE_BLOCK_SIZE"]
    assert device["largest_capacity"] == limit // PARTICLE_BYTES > 0
    assert len(device["limits"]["GL_MAX_COMPUTE_WORK_GROUP_COUNT"]) == 3
    assert device["limits"]["GL_MAX_GEOMETRY_OUTPUT_VERTICES"] >= 64
    assert found["zenoh"]["version"] == metadata.version("eclipse-zenoh")
    assert found["zenoh"]["opened"] and found["zenoh"]["listen"] == ["tcp/127.0.0.1:0"]
    assert set(found["windows"]) >= {"glfw", "display", "can_open", "reason"}
    assert found["verdict"]["ok"] and found["verdict"]["fix"] == ""
    for shown in ("EGL devices", "GL limits", "GL_MAX_SHADER_STORAGE_BLOCK_SIZE", "zenoh-python",
                  "ok: this node can run cavesim"):
        assert shown in result.stdout
    assert result.stderr == ""


def test_doctor_without_an_egl_driver_gives_the_reason_and_the_fix(tmp_path):
    result = doctor(tmp_path, env={"__EGL_VENDOR_LIBRARY_FILENAMES": "/nonexistent.json"})
    assert result.returncode == 1
    assert result.stderr.startswith("cavesim doctor: this node cannot run cavesim: ")
    assert result.stderr.count("\n") == 1 and "Traceback" not in result.stdout + result.stderr
    assert "EGL_EXT_device_enumeration" in result.stderr and "fix: install" in result.stderr
    assert "cannot run cavesim" not in result.stdout, "said once, on stderr"
    found = json.loads((tmp_path / "doctor.json").read_text())
    assert found["devices"] == [] and not found["verdict"]["ok"]
    assert found["egl"]["vendor_files"] == "/nonexistent.json"


@pytest.mark.parametrize(("args", "message"), [
    (("--connect", "nohost"), "endpoint 'nohost' must look like tcp/HOST:PORT"),
    (("--session", "a/b"), "session must be 1-32 letters"),
])
def test_doctor_checks_its_flags_as_a_node_does(tmp_path, args, message):
    result = doctor(tmp_path, *args)
    assert result.returncode == 2 and message in result.stderr
    assert result.stderr.count("\n") == 1


def test_doctor_refuses_an_output_it_cannot_write(tmp_path):
    (tmp_path / "file").write_text("")
    result = subprocess.run([sys.executable, "-m", "cavesim", "doctor", "--out",
                             str(tmp_path / "file" / "doctor.json")], capture_output=True,
                            text=True, timeout=60)
    assert result.returncode == 2 and result.stderr.count("\n") == 1
    assert f"argument --out: {str(tmp_path / 'file' / 'doctor.json')!r}: " \
           f"{str(tmp_path / 'file')!r} is a file, not a folder" in result.stderr


def test_doctor_runs_from_a_source_tree_pip_never_installed(monkeypatch):
    from cavesim.tools.doctor import report

    def not_installed(name):
        raise metadata.PackageNotFoundError(name)

    monkeypatch.setattr(report.metadata, "version", not_installed)
    assert report.cavesim_version() == f"source tree at {ROOT} (not installed)"
