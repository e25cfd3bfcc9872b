"""Every decision cavesim takes about a driver, against drivers this machine does not have.

Each profile in tests/data/drivers/ (NVIDIA's EGL on an H100, Mesa on an AMD GPU beside
llvmpipe, llvmpipe alone) answers cavesim's EGL and GL questions through a recorded
driver (`driver_doubles.py`); the device listing, the choice of devices for walls, the
context's version, the capacity and the doctor's verdict must each come out right.
"""

import ast
import copy
from pathlib import Path

import numpy as np
import pytest
from driver_doubles import RecordedDriver, load_profile, profile_names
from scenes import FOUNTAIN, scene_dict

from cavesim.core.errors import ContextError, FieldError
from cavesim.core.features.feature import Texture
from cavesim.core.scene import load_scene, parse_scene
from cavesim.core.scene.model import ENGINE_PATHS, Engine
from cavesim.core.wire.network import NetworkSettings
from cavesim.gpu.engine.capacity import capacity_limits, check_texture
from cavesim.gpu.engine.counter_buffer import counted_here
from cavesim.gpu.gl.context import REQUIRED_GL_VERSION, create_context
from cavesim.gpu.gl.devices import list_devices
from cavesim.gpu.gl.fence import FIRST_WAIT_NS, WAIT_LIMIT_SECONDS, first_wait_ns
from cavesim.gpu.gl.primitive_counts import query_buffers_offered
from cavesim.gpu.gl.vendors import UNKNOWN, VENDORS, vendor_of
from cavesim.gpu.shader_source import ShaderSource
from cavesim.tools.doctor.probe import examine
from cavesim.tools.doctor.report import gather
from cavesim.tools.doctor.verdict import judge
from nodes.launch.gpus import spread_walls

ROOT = Path(__file__).resolve().parents[2]
WALLS = ["front", "left", "right", "floor"]
PROFILES = profile_names()


@pytest.fixture(params=PROFILES)
def profile(request) -> dict:
    return load_profile(request.param)


def vendor_fix(name: str) -> str:
    return next(vendor.fix for vendor in (*VENDORS, UNKNOWN) if vendor.name == name)


def recorded_smoke(ctx, fix):
    """The checksum programs cannot run on a recording: the doctor's smoke test is the only
    GL work left out (it runs on every real device, this machine's in test_doctor.py)."""
    return {"ok": True, "detail": "recorded driver: programs not run"}, []


def test_the_three_drivers_are_recorded():
    assert PROFILES == ["mesa_llvmpipe", "mesa_radeonsi", "nvidia_h100_580"]


def test_each_driver_lists_its_devices(profile):
    devices = list_devices(RecordedDriver(profile))
    assert [d.kind for d in devices] == profile["expect"]["kinds"]
    assert [d.index for d in devices] == list(range(len(devices)))


def test_nvidias_older_name_for_device_listing_is_enough():
    """NVIDIA's libEGL lists EGL_EXT_device_base, not EGL_EXT_device_enumeration."""
    nvidia = load_profile("nvidia_h100_580")
    client = nvidia["egl"]["client_extensions"].split()
    assert "EGL_EXT_device_base" in client and "EGL_EXT_device_enumeration" not in client
    (device,) = list_devices(RecordedDriver(nvidia))
    assert device.name == "NVIDIA H100 80GB HBM3" and device.drm_file is None


def test_a_driver_without_device_listing_is_named():
    nvidia = load_profile("nvidia_h100_580")
    nvidia["egl"]["client_extensions"] = "EGL_EXT_platform_base EGL_KHR_debug"
    with pytest.raises(ContextError, match="EGL_EXT_device_enumeration \\+ "
                                           "EGL_EXT_device_query or EGL_EXT_device_base"):
        list_devices(RecordedDriver(nvidia))


def test_walls_go_to_the_hardware_devices(profile):
    devices = list_devices(RecordedDriver(profile))
    assert spread_walls(WALLS, {}, devices) == profile["expect"]["walls_on"]


def test_every_context_asks_for_43_and_gets_its_limits(profile):
    driver = RecordedDriver(profile)
    ctx = create_context(driver=driver)
    assert driver.opened == 1 and ctx.version_code >= REQUIRED_GL_VERSION
    limits = capacity_limits(ctx.info)
    assert limits.max_capacity == profile["expect"]["largest_capacity"]
    assert limits.binding.name == profile["expect"]["capacity_bound"]


def test_a_context_opened_without_asking_would_be_refused_on_nvidia():
    """NVIDIA gives 3.3 to whoever asks for nothing: no storage blocks, no compute."""
    answers = load_profile("nvidia_h100_580")["contexts"][0]["asked"]
    assert answers["330"]["version_code"] == 330
    assert answers["330"]["GL_MAX_SHADER_STORAGE_BLOCK_SIZE"] is None
    assert answers["430"]["version_code"] == REQUIRED_GL_VERSION


def test_a_driver_that_cannot_give_43_is_told_the_fix_for_its_vendor(profile):
    """A driver too old: the fix names its own vendor's driver, never another's."""
    old = copy.deepcopy(profile)
    for device in old["contexts"]:
        device["asked"]["430"] = {**device["asked"]["430"], "version_code": 330,
                                  "GL_VERSION": "3.3 (too old)"}
    with pytest.raises(ContextError, match="OpenGL 4.3 core is required") as error:
        create_context(driver=RecordedDriver(old))
    vendor = profile["expect"]["vendor"]
    assert error.value.fix == vendor_fix(vendor)
    if vendor == "NVIDIA":
        assert "Mesa" not in error.value.fix and "NVIDIA" in error.value.fix


def test_the_vendor_is_known_before_and_after_a_context_opens(profile):
    device = profile["egl"]["devices"][0]
    context = profile["contexts"][0]["asked"]["430"]
    assert vendor_of(tuple(device["extensions"])).name == profile["expect"]["vendor"]
    assert vendor_of((), context).name == profile["expect"]["vendor"]


def test_a_driver_whose_waits_spin_is_polled_and_one_that_sleeps_is_left_to_wait(profile):
    device = profile["egl"]["devices"][0]
    context = profile["contexts"][0]["asked"]["430"]
    waited_ns = first_wait_ns(tuple(device["extensions"]), context)
    assert (waited_ns == FIRST_WAIT_NS) == profile["expect"]["waits_spin"]
    assert waited_ns in (FIRST_WAIT_NS, WAIT_LIMIT_SECONDS * 1e9)


def test_the_doctor_reaches_the_right_verdict(profile):
    driver = RecordedDriver(profile)
    findings = gather(NetworkSettings(listen=("tcp/127.0.0.1:0",)), driver,
                      lambda index, extensions: examine(index, driver, recorded_smoke))
    verdict = judge(findings)
    assert verdict.ok and verdict.reason == profile["expect"]["verdict"]
    assert verdict.largest_capacity == profile["expect"]["largest_capacity"]
    assert findings["egl"]["client_extensions"] == profile["egl"]["client_extensions"]
    assert driver.opened == len(profile["contexts"])


def test_the_doctor_names_a_device_that_cannot_run_and_its_fix(profile):
    old = copy.deepcopy(profile)
    for device in old["contexts"]:
        device["asked"]["430"] = {**device["asked"]["430"], "version_code": 330}
    driver = RecordedDriver(old)
    verdict = judge(gather(NetworkSettings(listen=("tcp/127.0.0.1:0",)), driver,
                           lambda index, extensions: examine(index, driver, recorded_smoke)))
    assert not verdict.ok and verdict.reason.startswith("no EGL device can run cavesim: ")
    assert verdict.fix == vendor_fix(profile["expect"]["vendor"])


def test_compile_logs_name_the_included_file(profile):
    source = ShaderSource(text="", files=("main.glsl", "include/helper.glsl"))
    explained = source.explain(profile["compile_log"])
    assert "include/helper.glsl:3" in explained and "\n1" not in "\n" + explained


# -- every context cavesim opens asks for GL 4.3 ---------------------------------------------

OPENERS = {"create_standalone_context", "create_context"}


def python_files() -> list[Path]:
    return [path for folder in ("cavesim", "tests", "deploy", "nodes")
            for path in sorted((ROOT / folder).rglob("*.py")) if ".venv" not in path.parts]


def opener_problems(text: str, where: str) -> list[str]:
    """Context creations in `text` that do not ask for 4.3: a moderngl opener without
    require=REQUIRED_GL_VERSION, cavesim's create_context given a version, or an opener
    inside a string (code a child process runs)."""
    problems = []
    for node in ast.walk(ast.parse(text)):
        if isinstance(node, ast.Constant) and isinstance(node.value, str) \
                and "create_standalone_context(" in node.value:
            problems.append(f"{where}:{node.lineno}: a string opens a context")
        if not isinstance(node, ast.Call):
            continue
        func = node.func
        name = func.attr if isinstance(func, ast.Attribute) else getattr(func, "id", None)
        if name not in OPENERS:
            continue
        require = [k.value for k in node.keywords if k.arg == "require"]
        if isinstance(func, ast.Attribute) and getattr(func.value, "id", None) == "moderngl":
            if not (require and getattr(require[0], "id", None) == "REQUIRED_GL_VERSION"):
                problems.append(f"{where}:{node.lineno}: moderngl.{name} does not ask for "
                                f"REQUIRED_GL_VERSION")
        elif require:
            problems.append(f"{where}:{node.lineno}: create_context takes no version")
    return problems


def test_every_context_creation_in_the_code_asks_for_43():
    scanned = [path for folder in ("cavesim", "tests", "deploy", "nodes")
               for path in sorted((ROOT / folder).rglob("*.py"))
               if path != Path(__file__)]  # this file's snippets are wrong on purpose
    assert len(scanned) > 100
    assert [problem for path in scanned
            for problem in opener_problems(path.read_text(), path.name)] == []


@pytest.mark.parametrize("code", [
    "moderngl.create_standalone_context(backend='egl')",
    "moderngl.create_standalone_context(backend='egl', require=330)",
    "moderngl.create_context()",
    "create_context(require=330)",
    "context.create_context(require=430)",
    "run('import moderngl; moderngl.create_standalone_context(backend=\"egl\")')",
])
def test_the_scan_finds_a_creation_that_does_not_ask(code):
    assert len(opener_problems(code, "snippet")) == 1


def test_the_scan_lets_a_creation_that_asks_pass():
    assert opener_problems("moderngl.create_context(require=REQUIRED_GL_VERSION)\n"
                           "create_context(device=1)\n", "snippet") == []



@pytest.mark.parametrize(("version_code", "extensions", "offered"), [
    (450, set(), True),  # llvmpipe, radeonsi: core from 4.4
    (430, {"GL_ARB_query_buffer_object"}, True),  # a 4.3 context that lists the extension
    (430, set(), False),  # one that does not: the host reads the counts
])
def test_query_buffers_come_from_the_version_or_the_extension(version_code, extensions,
                                                              offered):
    assert query_buffers_offered(version_code, extensions) is offered


def exits_counted(scene, engine, info) -> bool:
    return "domain_exits" in counted_here(scene, engine, info)


def test_each_recorded_context_says_whether_gs_tf_counts_domain_exits(profile):
    """GS/TF steps in its vertex stage, which counts exits only where the context lets it
    write storage: the recordings predate that limit, so none of them counts on GS/TF (the
    compute path always does); this context, read live, does. The drops, copied from the
    passes' own counts, are counted on both paths everywhere."""
    scene = parse_scene(scene_dict(emitters=[{**FOUNTAIN}]), name="grid")
    for context in profile["contexts"]:
        asked = context["asked"][str(REQUIRED_GL_VERSION)]
        assert exits_counted(scene, Engine.GS_TF, asked) is \
            profile["expect"]["gs_tf_counts_exits"]
        assert exits_counted(scene, Engine.COMPUTE, asked)
        assert all("capacity_drops" in counted_here(scene, engine, asked)
                   for engine in ENGINE_PATHS)


def test_this_context_counts_domain_exits_on_both_paths_where_the_flow_has_a_grid(ctx):
    assert ctx.info["GL_MAX_VERTEX_SHADER_STORAGE_BLOCKS"] >= 1
    grid = parse_scene(scene_dict(), name="grid")
    rotor = load_scene(ROOT / "config" / "scenes" / "brownout.toml")
    assert all(exits_counted(grid, engine, ctx.info) for engine in ENGINE_PATHS)
    assert not any(exits_counted(rotor, engine, ctx.info) for engine in ENGINE_PATHS)


def test_a_time_series_fits_the_3d_texture_size_each_context_reports(profile):
    """200 snapshots 32 texels deep stack to 6,400: beyond llvmpipe's 2,048, within the
    H100's 16,384; the refusal names the limit and the driver."""
    for context in profile["contexts"]:
        asked = context["asked"][str(REQUIRED_GL_VERSION)]
        largest = asked["GL_MAX_3D_TEXTURE_SIZE"]
        texture = Texture("flow_field", np.zeros((6400, 32, 32, 3), np.float32),
                          what="the field's texture (200 snapshot(s) stacked along z)",
                          fewer="snapshots or nodes")
        if largest >= 6400:
            check_texture(asked, texture)
        else:
            with pytest.raises(FieldError, match=f"\\(200 snapshot\\(s\\) stacked along z\\) "
                                                 f"would be 32 x 32 x 6400 texels, beyond "
                                                 f"GL_MAX_3D_TEXTURE_SIZE = {largest} on "):
                check_texture(asked, texture)


def test_each_recorded_context_says_whether_gs_tf_counts_stay_on_the_gpu(profile):
    """The context cavesim asks for (4.3): Mesa's say 4.5 and 4.6; NVIDIA's says 4.3.0 and
    keeps the counts on the GPU only where it lists the extension, which the recording does
    not hold."""
    for context in profile["contexts"]:
        asked = context["asked"][str(REQUIRED_GL_VERSION)]
        assert query_buffers_offered(asked["version_code"], set()) is \
            profile["expect"]["query_buffers"]
