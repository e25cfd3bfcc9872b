"""Module names say what they hold: two modules share a file name only where they are the
same role in parallel folders, and each such pair is named here and in a docstring of the
folders' package."""

from collections import defaultdict
from pathlib import Path

ROOT = Path(__file__).parents[2]
PACKAGES = ("cavesim", "nodes")
PARALLEL_ROLES = {  # file name: (the package whose docstring says so, the folders)
    "dispersion.py": ("cavesim/core/features", {"cavesim/core/features", "cavesim/core/twin",
                                                "cavesim/core/portable"}),
    "collision.py": ("cavesim/core/features", {"cavesim/core/features", "cavesim/core/twin"}),
    "forces.py": ("cavesim/core/portable", {"cavesim/core/twin", "cavesim/core/portable"}),
    "integrators.py": ("cavesim/core/portable", {"cavesim/core/twin", "cavesim/core/portable"}),
    "tracers.py": ("cavesim/core/features", {"cavesim/core/features", "cavesim/core/twin",
                                             "cavesim/core/portable"}),
    "rotor.py": ("cavesim/core/portable", {"cavesim/core/helicopter", "cavesim/core/portable"}),
    "emission.py": ("cavesim/core/twin", {"cavesim/core/twin", "cavesim/gpu/engine"}),
    "programs.py": ("cavesim/gpu", {"cavesim/gpu/engine", "cavesim/gpu/render"}),
    "report.py": ("cavesim/tools", {"cavesim/tools/bench", "cavesim/tools/doctor",
                                    "cavesim/tools/numerics", "cavesim/tools/stability"}),
    "display.py": ("cavesim/tools", {"cavesim/tools/bench", "cavesim/tools/numerics"}),
    "process.py": ("nodes", {"nodes/master", "nodes/wall"}),
    "settings.py": ("nodes", {"nodes/master", "nodes/wall"}),
}


def repeated_names() -> dict[str, set[str]]:
    folders = defaultdict(set)
    for package in PACKAGES:
        for path in (ROOT / package).rglob("*.py"):
            if path.name not in ("__init__.py", "__main__.py"):
                folders[path.name].add(str(path.parent.relative_to(ROOT)))
    return {name: found for name, found in folders.items() if len(found) > 1}


def test_only_parallel_roles_share_a_file_name():
    assert repeated_names() == {name: found for name, (_, found) in PARALLEL_ROLES.items()}


def test_each_parallel_role_is_named_in_its_package_docstring():
    unsaid = [name for name, (package, _) in PARALLEL_ROLES.items()
              if name.removesuffix(".py") not in (ROOT / package / "__init__.py").read_text()]
    assert unsaid == []
