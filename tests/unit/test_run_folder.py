"""Each run owns its output folder: a fresh one by default, a given one only if new, empty
or (with --force) a run's own, and never one another run is writing; a dead run leaves no
lock behind."""

import datetime
import importlib
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from nodes import cli
from nodes.arguments import RUN_ERROR, USAGE_ERROR, UsageError
from nodes.run_folder import LOCK, MARKER, claim, default_folder, link_latest

NOON = datetime.datetime(2026, 11, 28, 12, 0, 5)
ROOT = Path(__file__).parents[2]


def test_a_default_folder_is_named_by_command_and_start_and_never_reused(tmp_path):
    first = default_folder("run", NOON, tmp_path)
    assert first == tmp_path / "run-20261128-120005"
    first.mkdir()
    assert default_folder("run", NOON, tmp_path) == tmp_path / "run-20261128-120005-2"


def test_a_claimed_folder_is_marked_and_locked_until_released(tmp_path):
    out = tmp_path / "out"
    with claim(out, "run") as folder:
        marker = json.loads((out / MARKER).read_text())
        assert marker["command"] == "run" and marker["pid"] == os.getpid()
        with pytest.raises(UsageError, match=r"'.*out' is in use by another run \(cavesim run, "
                                             f"pid {os.getpid()} on .*\\); give another folder"):
            claim(out, "run")
        assert folder.path == out
    with claim(out, "run"):  # released: the same (still empty) folder is free again
        pass


def test_another_runs_files_are_refused_and_replaced_only_with_force(tmp_path):
    out = tmp_path / "out"
    with claim(out, "run"):
        (out / "report.json").write_text("{}")
        (out / "walls").mkdir()
        (out / "walls" / "front.png").write_bytes(b"png")
    with pytest.raises(UsageError, match=r"cavesim run: error: argument --out: '.*out' holds "
                                         r"another run's files \(report.json, walls\); give a new "
                                         "folder, leave --out off .* or add --force"):
        claim(out, "run")
    with claim(out, "run", force=True):
        assert sorted(p.name for p in out.iterdir()) == [MARKER, LOCK]


def test_force_never_deletes_a_folder_no_run_wrote(tmp_path):
    (tmp_path / "thesis.tex").write_text("years of work")
    with pytest.raises(UsageError, match=r"holds files a cavesim run did not write "
                                         r"\(thesis.tex\); --force replaces only a run's own"):
        claim(tmp_path, "run", force=True)
    assert (tmp_path / "thesis.tex").read_text() == "years of work"


def test_a_killed_run_leaves_no_lock_behind(tmp_path):
    out = tmp_path / "out"
    holder = subprocess.Popen(
        [sys.executable, "-c", "import sys, time; from pathlib import Path; "
         "from nodes.run_folder import claim; claim(Path(sys.argv[1]), 'run'); "
         "print('held', flush=True); time.sleep(60)", str(out)],
        cwd=ROOT, stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline() == "held\n"
        with pytest.raises(UsageError, match=f"pid {holder.pid} on "):
            claim(out, "run")
    finally:
        holder.kill()
        holder.wait(timeout=10)
    with claim(out, "run"):
        pass


def test_latest_points_at_the_newest_folder_of_its_command(tmp_path):
    for stamp in ("run-1", "run-2", "bench-1"):
        (tmp_path / stamp).mkdir()
        link_latest(tmp_path / stamp, stamp.split("-")[0])
    assert (tmp_path / "latest").resolve() == (tmp_path / "run-2").resolve()
    assert (tmp_path / "bench-latest").resolve() == (tmp_path / "bench-1").resolve()


def test_the_command_refuses_a_used_folder_and_force_without_out(tmp_path, capsys):
    (tmp_path / "frames.log").write_bytes(b"")
    assert cli.main(["run", "--walls", "1", "--out", str(tmp_path)]) == USAGE_ERROR
    assert "holds another run's files (frames.log)" in capsys.readouterr().err
    assert cli.main(["run", "--walls", "1", "--force"]) == USAGE_ERROR
    assert "argument --force: replaces the files in the folder --out names; give --out too" \
        in capsys.readouterr().err


# -- every command that writes result files ----------------------------------------------------

COMMANDS = {  # argv, and the function of its run that the default-folder test stops at
    "check": (["check", "--walls", "1"], "nodes.check.harness.run_check"),
    "bench": (["bench", "--quick"], "cavesim.tools.bench.run_bench"),
    "accuracy": (["accuracy", "--quick"], "cavesim.tools.numerics.run_command"),
    "stability": (["stability"], "cavesim.gpu.gl.context.create_context"),
    "render": (["render", str(ROOT / "tests/data/logs/vortex_portable.log"), "--scene",
                str(ROOT / "tests/data/logs/vortex_portable.toml")],
               "cavesim.tools.log_render.render_log"),
}


class _Stopped(Exception):
    pass


def _stop(*args, **kwargs):
    raise _Stopped("stopped where the work begins")


@pytest.mark.parametrize("command", COMMANDS)
def test_a_command_refuses_a_used_folder_one_in_use_and_force_without_out(command, tmp_path,
                                                                         capsys):
    argv, _ = COMMANDS[command]
    (tmp_path / "notes.txt").write_text("mine")
    assert cli.main([*argv, "--out", str(tmp_path)]) == USAGE_ERROR
    assert capsys.readouterr().err == (
        f"cavesim {command}: error: argument --out: {str(tmp_path)!r} holds another run's "
        "files (notes.txt); give a new folder, leave --out off for a fresh one under out/, "
        "or add --force to replace them\n")
    assert cli.main([*argv, "--force"]) == USAGE_ERROR
    assert f"cavesim {command}: error: argument --force: replaces the files in the folder " \
           "--out names; give --out too" in capsys.readouterr().err
    busy = tmp_path / "busy"
    with claim(busy, "run"):
        assert cli.main([*argv, "--out", str(busy)]) == USAGE_ERROR
    assert "is in use by another run (cavesim run, pid" in capsys.readouterr().err
    assert (tmp_path / "notes.txt").read_text() == "mine"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["busy", "notes.txt"]  # nothing left
    assert json.loads((busy / MARKER).read_text())["command"] == "run"
    assert sorted(p.name for p in busy.iterdir()) == [MARKER, LOCK]


@pytest.mark.parametrize("command", COMMANDS)
def test_a_command_without_out_writes_a_fresh_folder_its_latest_link_names(
        command, tmp_path, monkeypatch, capsys):
    argv, work = COMMANDS[command]
    module, name = work.rsplit(".", 1)
    monkeypatch.setattr(importlib.import_module(module), name, _stop)
    monkeypatch.chdir(tmp_path)
    assert cli.main(argv) == RUN_ERROR
    assert "stopped where the work begins" in capsys.readouterr().err
    (folder,) = (tmp_path / "out").glob(f"{command}-2*")
    assert (folder / MARKER).is_file()
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == [
        folder.name, f"{command}-latest"]  # out/latest stays `cavesim run`'s
    assert (tmp_path / "out" / f"{command}-latest").resolve() == folder.resolve()

