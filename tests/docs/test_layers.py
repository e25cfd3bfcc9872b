"""The layers point one way: cavesim.core -> cavesim.gpu -> cavesim.tools -> nodes, and
nothing imports in a circle.

Read from the source (every `import` and `from ... import`, at module level or inside a
function), so a late import cannot hide an upward edge; and run: the core, the wire, the
master's whole loop and the tracker bridge work in a process where moderngl cannot be
imported.
"""

import ast
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).parents[2]
PACKAGES = ("cavesim", "nodes")
LAYERS = ("cavesim.core", "cavesim.gpu", "cavesim.tools", "nodes")  # each imports those before
ENTRY_POINTS = {"cavesim.__main__"}  # `python -m cavesim`: the command line itself
SIDES = ("nodes.master", "nodes.wall")  # the two ends of the wire share only what lies below


def module_name(path: Path) -> str:
    parts = path.relative_to(ROOT).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def imports(path: Path) -> set[str]:
    """The project's modules `path` imports: `from package import name` counts the module
    `package.name` where there is one, else the package."""
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            found |= {a.name for a in node.names if a.name.split(".")[0] in PACKAGES}
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0 \
                and node.module.split(".")[0] in PACKAGES:
            names = {f"{node.module}.{a.name}" for a in node.names}
            found |= (names & MODULES.keys()) or {node.module}
            if names - MODULES.keys():
                found.add(node.module)
    return found


MODULES = {module_name(p): p for package in PACKAGES for p in (ROOT / package).rglob("*.py")}
GRAPH = {name: imports(path) & set(MODULES) for name, path in MODULES.items()}


def layer(module: str) -> int | None:
    for rank, prefix in reversed(list(enumerate(LAYERS))):
        if module == prefix or module.startswith(prefix + "."):
            return rank
    return None


def test_every_module_lives_in_a_layer():
    outside = sorted(m for m in MODULES if layer(m) is None
                     and m not in ENTRY_POINTS and m != "cavesim")
    assert outside == []


def test_no_import_points_up_a_layer():
    upward = sorted(f"{m} -> {target}" for m, targets in GRAPH.items() for target in targets
                    if m not in ENTRY_POINTS and layer(m) is not None
                    and layer(target) is not None and layer(target) > layer(m))
    assert upward == []


def test_an_upward_import_would_be_found():
    assert layer("cavesim.tools.doctor.report") < layer("nodes.commands.doctor")
    assert layer("cavesim.core.wire") < layer("cavesim.gpu.engine") < layer("cavesim.tools")


def test_the_development_guide_draws_these_layers_top_down():
    layout = (ROOT / "docs/development.md").read_text().split("## Layout\n", 1)[1]
    picture = layout.split("```\n", 2)[1]
    rooms = [line.split()[0] for line in picture.splitlines() if line[:1].isalpha()]
    assert rooms == [prefix.replace(".", "/") + "/" for prefix in reversed(LAYERS)]


def test_the_package_roots_import_nothing():
    assert GRAPH["cavesim"] == set()  # `import cavesim` loads no GL and no process
    assert GRAPH["nodes"] == set()


def test_the_master_and_the_wall_do_not_import_each_other():
    crossing = sorted(f"{m} -> {target}" for m, targets in GRAPH.items() for target in targets
                      for side, other in (SIDES, SIDES[::-1])
                      if m.startswith(side + ".") and target.startswith(other + "."))
    assert crossing == []


def test_no_modules_import_each_other_in_a_circle():
    cycles = _cycles(GRAPH)
    assert cycles == [], "\n".join(" -> ".join(c) for c in cycles)


def test_a_circle_would_be_found():
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan), each sorted."""
    index, low, stack, on_stack, found = {}, {}, [], set(), []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


BLOCKED_GL = """
import importlib, pkgutil, sys
sys.modules["moderngl"] = None  # `import moderngl` raises ImportError from here on
sys.path.insert(0, "tests/support")
import cavesim.core
for module in pkgutil.walk_packages(cavesim.core.__path__, "cavesim.core."):
    importlib.import_module(module.name)
from memory_walls import MemoryLink
from nodes.master.process import MasterConfig, run_master
link = MemoryLink(("front", "left", "right"), scene="config/scenes/brownout.toml")
link.walls["left"].flip_at.add(5)
record = run_master(MasterConfig(("front", "left", "right"),
                                 "config/scenes/brownout.toml", 20, "nogl"), link)
assert record.frames == 20 and record.final.agree, record.summary()
assert [d.nodes for d in record.divergences] == [("left",)]
assert len(record.flight) == 20  # the helicopter's driver ran on the master
from cavesim.core.tracking import load_mapping
from nodes.tracker.bridge import Bridge
sent = []
Bridge(load_mapping("config/tracking/dtrack.toml"), sent.append).receive(b"fr 1\\r\\n6d 0\\r\\n", 0)
assert [m.frame for m in sent] == [1]
assert "moderngl" not in {m for m in sys.modules if sys.modules[m] is not None}
print("ok")
"""


@pytest.mark.slow
def test_core_wire_master_and_tracker_run_where_moderngl_cannot_be_imported():
    done = subprocess.run([sys.executable, "-c", BLOCKED_GL], cwd=ROOT, capture_output=True,
                          text=True, timeout=120)
    assert done.returncode == 0 and done.stdout.strip() == "ok", done.stderr
