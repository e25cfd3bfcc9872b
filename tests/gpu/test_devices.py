"""EGL devices and the choice of one: listing, bad indices, glcontext's override variable."""

import os
import subprocess
import sys

import moderngl
import pytest

from cavesim.core.errors import ContextError
from cavesim.gpu.gl import context
from cavesim.gpu.gl.devices import EglDevice, find_device, list_devices


def test_this_machine_lists_its_devices_in_glcontext_order():
    devices = list_devices()
    assert devices and [d.index for d in devices] == list(range(len(devices)))
    for device in devices:  # llvmpipe where Mesa is installed, a GPU's own device elsewhere
        assert device.software == ("EGL_MESA_device_software" in device.extensions)
        assert device.kind == ("software" if device.software else "hardware")


def test_the_session_context_names_its_device(ctx):
    gpu = context.gpu_of(ctx)
    assert gpu["device"] == 0 and gpu["kind"] == list_devices()[0].kind
    assert gpu["renderer"] == ctx.info["GL_RENDERER"] and gpu["version"].startswith("4.")


def test_kind_comes_from_the_software_extension():
    gpu = EglDevice(1, ("EGL_EXT_device_drm",), drm_file="/dev/dri/card1")
    assert gpu.kind == "hardware" and gpu.summary()["drm_file"] == "/dev/dri/card1"
    assert EglDevice(0, ("EGL_MESA_device_software",)).kind == "software"


def test_an_index_past_the_devices_names_the_index_the_count_and_doctor():
    count = len(list_devices())
    with pytest.raises(ContextError) as error:
        context.create_context(device=count)  # fails before any context is made
    message = str(error.value)
    assert message.startswith(f"cannot open a headless OpenGL context: EGL device {count} "
                              f"does not exist")
    assert f"this machine has {count} EGL device(s) (device 0 is " in message
    assert "`cavesim doctor`" in error.value.fix and "\n" not in message


def test_a_failing_device_names_its_index_and_the_count(monkeypatch):
    def refuse(**kwargs):
        raise Exception(f"eglInitialize failed\non device {kwargs['device_index']}")

    monkeypatch.setattr(moderngl, "create_standalone_context", refuse)
    with pytest.raises(ContextError) as error:
        context.create_context(device=0)
    message = str(error.value)
    devices = list_devices()
    assert f"on device 0 ({devices[0].kind}, one of {len(devices)})" in message
    assert "eglInitialize failed on device 0" in message and "\n" not in message
    assert "cavesim doctor" in message


@pytest.mark.parametrize(("value", "device", "match"), [
    ("1", 0, "GLCONTEXT_DEVICE_INDEX=1 would override the requested EGL device 0"),
    ("one", None, "GLCONTEXT_DEVICE_INDEX='one' is not an EGL device index"),
])
def test_glcontext_device_variable_may_not_contradict_the_choice(monkeypatch, value, device,
                                                                  match):
    monkeypatch.setenv("GLCONTEXT_DEVICE_INDEX", value)
    with pytest.raises(ContextError, match=match):
        context.create_context(device=device)


def test_glcontext_device_variable_alone_picks_the_device(monkeypatch):
    monkeypatch.setenv("GLCONTEXT_DEVICE_INDEX", "0")
    assert find_device(context._device_index(None))[0].index == 0


def test_a_missing_libegl_is_named_with_the_packages(monkeypatch):
    monkeypatch.setenv("GLCONTEXT_LINUX_LIBEGL", "/nonexistent/libEGL.so.1")
    with pytest.raises(ContextError, match="cannot load /nonexistent/libEGL.so.1.*libegl1"):
        list_devices()


def test_no_egl_driver_is_named_with_the_variable_and_the_packages():
    """glvnd reads its vendor files when libEGL loads: this needs a fresh process."""
    code = ("from cavesim.gpu.gl.context import create_context\n"
            "from cavesim.core.errors import ContextError\n"
            "try:\n    create_context()\nexcept ContextError as e:\n    print(e)\n")
    env = {**os.environ, "__EGL_VENDOR_LIBRARY_FILENAMES": "/nonexistent.json"}
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                            env=env, timeout=60)
    assert result.returncode == 0, result.stderr
    assert "no EGL driver offers EGL_EXT_device_enumeration" in result.stdout
    assert "or EGL_EXT_device_base" in result.stdout
    assert "'/nonexistent.json'" in result.stdout and "libegl-mesa0" in result.stdout
