"""Every physics feature is a room: its keys, rules, defines and coordinates are declared in
its own module, and what the loader, the shaders and the gate do with them follows from the
declarations (cavesim/core/features/)."""

import dataclasses
import io
import itertools
import tokenize
import typing
from pathlib import Path
from typing import Annotated

import pytest
from scenes import FOUNTAIN, SMOKE, make_scene, scene_dict

from cavesim.core._schema import Coordinate
from cavesim.core.errors import SceneError
from cavesim.core.features import origin
from cavesim.core.features.registry import (
    FEATURES,
    IDS,
    PASS_DEFINES,
    RULES,
    features_of,
    pass_defines,
    possible,
)
from cavesim.core.features.rules import evaluate, glsl_checks
from cavesim.core.scene import parse_scene
from cavesim.core.scene.file import FIELD_PARAMS, SceneFile


def table_of(key: str) -> type:
    """The dataclass that holds a dotted key of a scene file (array indices left out)."""
    table = SceneFile
    for part in key.split(".")[:-1]:
        hint = typing.get_type_hints(table)[part]
        table = _table(hint)
    return table


def _table(hint) -> type:
    for arg in (hint, *typing.get_args(hint), *itertools.chain.from_iterable(
            typing.get_args(a) for a in typing.get_args(hint))):
        if dataclasses.is_dataclass(arg):
            return arg
    raise AssertionError(f"no table in {hint}")


def test_each_feature_owns_keys_of_the_scene_file_and_no_two_own_one():
    owned = [key for feature in FEATURES for key in feature.keys]
    assert len(owned) == len(set(owned))
    for key in owned:
        assert key.split(".")[-1] in {f.name for f in dataclasses.fields(table_of(key))}, key


def test_each_define_of_the_particle_pass_belongs_to_one_feature_or_the_base():
    named = [name for feature in FEATURES for name in feature.defines]
    assert len(named) == len(set(named))
    assert set(PASS_DEFINES) == {"ARITHMETIC", "INTEGRATOR", "CLASS_COUNT", *named}
    for feature in FEATURES:
        off = feature.off()
        assert all(off[name] == values[0] for name, values in feature.defines.items())


@pytest.mark.parametrize("rule", RULES, ids=lambda r: f"{r.subject} needs {r.needs}")
def test_each_rule_refuses_the_combinations_that_break_it_and_no_other(rule):
    """A combination of defines that breaks the rule is impossible for the gate and stopped
    by the shaders' #error; one that keeps every rule is possible."""
    scene = make_scene()
    values = pass_defines(scene)
    assert possible(values)
    broken = _breaking(rule, values)
    assert not possible(broken)
    assert f"#if ({rule.subject}) && !({rule.needs})" in glsl_checks(RULES)


def _breaking(rule, values):
    """A combination near `values` whose subject holds and whose needs do not."""
    names = [n for n in PASS_DEFINES if n in rule.subject or n in rule.needs]
    for changed in itertools.product(*(PASS_DEFINES[n] for n in names)):
        candidate = {**values, **dict(zip(names, changed, strict=True))}
        if rule.broken({**IDS, **candidate}):
            return candidate
    raise AssertionError(f"no combination breaks {rule}")


def test_a_rule_condition_reads_as_the_preprocessor_reads_it():
    values = {"A": 1, "B": 0, "C": 2}
    assert evaluate("A && !B", values)
    assert evaluate("C == 2 || B", values)
    assert evaluate("!(A && C != 2)", values) and not evaluate("!(A && C == 2)", values)
    assert evaluate("C >= 2 && C < 3", values)
    with pytest.raises(KeyError):
        evaluate("D", values)
    with pytest.raises(ValueError, match="cannot read"):
        evaluate("A; import os", values)


@pytest.mark.parametrize(("data", "needle"), [
    ({"forces": {"dispersion": {"mixing_length": 5.0}}},
     "forces.dispersion: needs forces.drag"),
    ({"forces": {"drag": {}, "dispersion": {"mixing_length": 5.0}},
      "field": scene_dict()["field"]}, "forces.dispersion: needs [collision]"),
    ({"particle_class": [{"name": "smoke", "diameter": 1e-5, "motion": "tracer"}],
      "forces": {}}, "particle_class[0].motion = 'tracer' is not allowed: \"tracer\" needs "
                     "forces.drag"),
    ({"particle_class": [{"name": "sand", "diameter": 1e-3, "density": 2650.0,
                          "drag": "schiller_naumann"}], "forces": {}},
     "particle_class[0].drag = 'schiller_naumann' is not allowed: a drag law acts through "
     "forces.drag"),
])
def test_the_loader_refuses_a_broken_rule_in_one_line_naming_the_key(data, needle):
    base = scene_dict(drag=False, gravity=False)
    base["emitter"] = []
    with pytest.raises(SceneError) as caught:
        parse_scene({**base, **data}, name="test")
    assert needle in str(caught.value) and "\n" not in str(caught.value)


def test_the_features_of_a_scene_are_those_it_has():
    assert [f.name for f in features_of(make_scene(drag=False, gravity=False))] == []
    names = [f.name for f in features_of(make_scene(collision={
        "kind": "plane", "friction": 0.1, "resilience": 0.5}))]
    assert names == ["gravity", "stokes_drag", "schiller_naumann", "grid_flow", "collision"]


def test_every_key_marked_a_coordinate_moves_with_the_origin():
    data = scene_dict(emitters=[FOUNTAIN], collision={
        "kind": "plane", "friction": 0.1, "resilience": 0.5, "height": 2.0})
    data["simulation"]["origin"] = [100.0, -200.0, 3.0]
    moved = parse_scene(data, name="test")
    data["simulation"].pop("origin")
    world = parse_scene(data, name="test")
    assert moved.emitters[0].position == tuple(
        p - o for p, o in zip(world.emitters[0].position, (100.0, -200.0, 3.0), strict=True))
    assert moved.field.box_min == (-104.0, 196.0, -3.0)
    assert moved.field.params["center"] == (0.3 - 100.0, -0.2 + 200.0)
    assert moved.collision.height == -1.0
    assert moved.field.params["circulation"] == world.field.params["circulation"]


def test_a_new_table_with_a_coordinate_moves_by_its_mark_alone():
    @dataclasses.dataclass(frozen=True)
    class Beacon:
        where: Annotated[tuple[float, float, float], Coordinate()]
        floor: Annotated[float, Coordinate("z")] | None = None
        brightness: float = 1.0

    @dataclasses.dataclass(frozen=True)
    class Holder:
        beacons: tuple[Beacon, ...]

    held = Holder((Beacon((1.0, 2.0, 3.0), 4.0), Beacon((0.0, 0.0, 0.0))))
    moved = origin._moved(held, (1.0, 1.0, 1.0))
    assert moved == Holder((Beacon((0.0, 1.0, 2.0), 3.0), Beacon((-1.0, -1.0, -1.0))))


def test_the_field_kinds_mark_their_centres_and_ground():
    marked = {kind.value: origin.coordinates(params) for kind, params in FIELD_PARAMS.items()}
    assert marked["vortex"] == {"center": Coordinate("xy")}
    assert marked["downwash"] == {"rotor_center": Coordinate(), "ground_height": Coordinate("z")}
    assert marked["uniform"] == marked["rotating"] == marked["file"] == {}


def test_a_tracer_scene_compiles_its_method_and_a_smoke_class_is_one():
    data = scene_dict(integrator="rk4")
    data["particle_class"] = [data["particle_class"][0], SMOKE]
    values = pass_defines(parse_scene(data, name="smoke"))
    assert values["HAS_TRACERS"] == 1 and values["TRACER_METHOD"] == IDS["TRACER_RK4"]


HUBS = ("cavesim/gpu/engine/particle_system.py", "cavesim/gpu/engine/feature_resources.py",
        "cavesim/gpu/engine/programs.py", "cavesim/core/twin/system.py")
# what a hub names for another reason: the twin steps a tracer class by its method (the
# motion itself, as the GPU's `advance` does) and spawns a helicopter's emission at its
# `origin`, the point below the hub
OTHER_SENSES = {("cavesim/core/twin/system.py", "tracers"),
                ("cavesim/core/twin/system.py", "origin")}


def code_names(path: str) -> set[str]:
    """The names a module's code uses (not its comments, docstrings or strings)."""
    source = (Path(__file__).parents[2] / path).read_text()
    return {token.string for token in tokenize.generate_tokens(io.StringIO(source).readline)
            if token.type == tokenize.NAME}


@pytest.mark.parametrize("hub", HUBS)
def test_the_hubs_iterate_over_the_features_and_name_none(hub):
    """The programs, the engine, the twin and the loader take what a feature adds from its
    room: none names a feature, one of its defines or one of its keys."""
    names = code_names(hub)
    for feature in FEATURES:
        if (hub, feature.name) in OTHER_SENSES:
            continue
        own = {feature.name, feature.name.upper(), *feature.defines,
               *(key.split(".")[-1] for key in feature.keys if "." in key)}
        assert not names & own, f"{hub} names {sorted(names & own)} of {feature.name}"


def test_the_loader_reads_the_tables_and_leaves_the_rules_to_the_features():
    """The loader reads each table of the file by its kind (which keys a [collision] plane
    or a tracer's [[particle_class]] takes); what the features require of each other is
    the rule table's: it names no define, and calls no rule of its own."""
    names = code_names("cavesim/core/scene/loader.py")
    assert not names & set(PASS_DEFINES)
    assert not {"_check_dispersion", "_check_tracers", "reachable"} & names
