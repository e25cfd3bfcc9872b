"""The shell commands of the README and the docs cannot rot.

Every ```sh block is either run here as written (in a scratch folder holding the project's
`config/` and `.venv/`), or marked ```sh illustrative: it needs a cluster, a GPU, a display
or an hour. Every `cavesim` command of either kind names a subcommand and flags that exist.
"""

import re
import shlex
import subprocess
from pathlib import Path

import pytest

from nodes.arguments import UsageError
from nodes.cli import build_parser

ROOT = Path(__file__).parents[2]
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]
FENCE = re.compile(r"^```([^\n]*)\n(.*?)^```", re.S | re.M)
SHELLS = ("sh", "bash", "shell", "console", "zsh")


def _blocks() -> list[tuple[str, bool, str]]:
    """(where, illustrative, body) of every ```sh block."""
    found = []
    for doc in DOCS:
        for info, body in FENCE.findall(doc.read_text()):
            words = info.split()
            if words and words[0] in SHELLS:
                line = doc.read_text()[:doc.read_text().index(body)].count("\n") + 1
                found.append((f"{doc.relative_to(ROOT)}:{line}", words[1:] == ["illustrative"],
                              body))
    return found


BLOCKS = _blocks()
RUN = [b for b in BLOCKS if not b[1]]


def _commands(body: str) -> list[list[str]]:
    """Each command line of a block as argv: continuations joined, comments and leading
    VAR=value assignments dropped."""
    argvs = []
    for line in body.replace("\\\n", " ").splitlines():
        argv = shlex.split(line, comments=True)
        while argv and re.fullmatch(r"[A-Z_]+=.*", argv[0]):
            argv = argv[1:]
        if argv:
            argvs.append(argv)
    return argvs


def test_shell_blocks_are_sh_and_marked_one_way():
    for where, _, body in BLOCKS:
        assert body.strip(), f"{where}: an empty block"
    infos = {info for doc in DOCS for info, _ in FENCE.findall(doc.read_text())
             if info.split()[:1] and info.split()[0] in SHELLS}
    assert infos <= {"sh", "sh illustrative"}, infos


@pytest.mark.parametrize("where,illustrative,body", BLOCKS, ids=[b[0] for b in BLOCKS])
def test_every_cavesim_command_names_flags_that_exist(where, illustrative, body):
    for argv in _commands(body):
        if Path(argv[0]).name != "cavesim" or "--help" in argv:
            continue
        try:
            build_parser().parse_args(argv[1:])
        except UsageError as e:  # a value this machine lacks (another host's file) is fine
            assert not re.search(r"unrecognized arguments|invalid choice|required",
                                 str(e)), f"{where}: {shlex.join(argv)}: {e}"


@pytest.mark.slow
@pytest.mark.parametrize("where,illustrative,body", RUN, ids=[b[0] for b in RUN])
def test_every_block_not_illustrative_runs_as_written(where, illustrative, body, tmp_path):
    """Run as a user would, from a folder with the project's config and virtualenv."""
    for name in ("config", ".venv"):
        (tmp_path / name).symlink_to(ROOT / name)
    result = subprocess.run(["bash", "-euo", "pipefail", "-c", body], cwd=tmp_path,
                            capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, f"{where}:\n{body}\n{result.stdout}\n{result.stderr}"
