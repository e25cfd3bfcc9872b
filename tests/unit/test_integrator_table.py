"""The `Integrator` table is the one place an integrator is declared: every row is complete,
the shaders and both twins follow it, and no other module keeps a list of its own."""

import re
from pathlib import Path

import pytest

from cavesim.core.features.registry import GLSL_IDS
from cavesim.core.portable import integrators as portable_integrators
from cavesim.core.portable import tracers as portable_tracers
from cavesim.core.scene.model import Integrator, TracerMethod
from cavesim.core.twin import integrators as twin_integrators
from cavesim.core.twin import tracers as twin_tracers
from cavesim.gpu.shader_source import SHADER_ROOT

PACKAGE = Path(__file__).parents[2] / "cavesim"
INCLUDES = SHADER_ROOT / "include"
PHYSICS = "".join((INCLUDES / name).read_text()  # the particle step's integrators and tracers
                  for name in ("physics.glsl", "integrators.glsl", "tracers.glsl"))
SHADERS = "".join(path.read_text() for path in SHADER_ROOT.rglob("*.glsl"))


def preamble_ids(prefix: str) -> dict[str, int]:
    """The ids the particle pass's preamble defines with `prefix`, by name."""
    return {name.removeprefix(prefix): number for name, number in GLSL_IDS.items()
            if name.startswith(prefix)}


def integrate_branches() -> list[str]:
    """The integrators `integrate` in integrators.glsl has a branch for, in order."""
    body = PHYSICS[PHYSICS.index("void integrate("):]
    body = body[:body.index("\n}\n")]
    return re.findall(r"^#(?:el)?if INTEGRATOR == INTEGRATOR_(\w+)$", body, re.MULTILINE)


@pytest.mark.parametrize("integrator", list(Integrator), ids=lambda i: i.value)
def test_every_row_is_complete(integrator):
    assert type(integrator.gpu_id) is int and integrator.gpu_id >= 0
    assert type(integrator.order) is int and integrator.order >= 1
    assert type(integrator.field_evaluations) is int and integrator.field_evaluations >= 1
    assert isinstance(integrator.stability_limit, float) and integrator.stability_limit > 0
    assert isinstance(integrator.tracer_method, TracerMethod)
    assert integrator.value == integrator.name.lower()


def test_the_gpu_ids_are_distinct_and_the_shaders_own():
    ids = [i.gpu_id for i in Integrator]
    assert len(set(ids)) == len(ids)
    assert preamble_ids("INTEGRATOR_") == {i.name: i.gpu_id for i in Integrator}
    assert not re.search(r"#define INTEGRATOR_", SHADERS)  # the table's, not written twice


def test_integrate_has_one_branch_per_integrator():
    assert integrate_branches() == [i.name for i in Integrator]


@pytest.mark.parametrize("module", [twin_integrators, portable_integrators],
                         ids=["float64", "portable"])
def test_each_twin_steps_every_integrator_with_the_function_of_its_name(module):
    assert list(module.INTEGRATORS) == list(Integrator)
    for integrator, step in module.INTEGRATORS.items():
        assert step is getattr(module, integrator.value) and callable(step)


def test_no_other_module_lists_the_integrators():
    """A module naming every integrator (as a member or as its name in a scene file) holds a
    second table, which a new integrator would miss."""
    table = PACKAGE / "core" / "scene" / "model.py"

    def names_every_integrator(text: str) -> bool:
        return all(f"Integrator.{i.name}" in text or f'"{i.value}"' in text for i in Integrator)

    listing = [path.relative_to(PACKAGE).as_posix() for path in sorted(PACKAGE.rglob("*.py"))
               if path != table and names_every_integrator(path.read_text())]
    assert listing == []


# -- passive tracers: the TracerMethod table and each integrator's column naming one ----


def trace_branches() -> list[str]:
    """The tracer methods `trace` in tracers.glsl has a branch for, in order."""
    body = PHYSICS[PHYSICS.index("void trace("):]
    body = body[:body.index("\n}\n")]
    return re.findall(r"^#(?:el)?if TRACER_METHOD == TRACER_(\w+)$", body, re.MULTILINE)


def test_every_tracer_method_but_the_adaptive_one_is_an_integrators_form_without_inertia():
    assert {i.tracer_method for i in Integrator} == set(TracerMethod) - {TracerMethod.RK45}
    assert all(type(m.gpu_id) is int and type(m.order) is int and m.field_evaluations >= 1
               for m in TracerMethod)


def test_the_tracer_methods_are_the_shaders_and_both_twins():
    assert preamble_ids("TRACER_") == {m.name: m.gpu_id for m in TracerMethod}
    assert not re.search(r"#define TRACER_(EULER|RK4)\b", SHADERS)
    assert trace_branches() == [m.name for m in TracerMethod]
    for module in (twin_tracers, portable_tracers):
        assert list(module.TRACERS) == list(TracerMethod)
        for method, step in module.TRACERS.items():
            assert step is getattr(module, method.value) and callable(step)
