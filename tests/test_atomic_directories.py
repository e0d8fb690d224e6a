"""The project's file handling: a directory swapped into place survives a kill between its steps."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from simgap.errors import InputError
from simgap.files import publish, replace_directory, restore_directory, staged_directory

SRC = Path(__file__).resolve().parents[1] / "src"

# swap a new directory into argv[1], the process killed (SIGKILL: no cleanup runs) right after
# rename number argv[2] (1: the old directory set aside; 2: the new one moved in)
KILLED_SWAP = """
import os, signal, sys
import simgap.files as files

renames, real = [0], os.replace

def replace_then_die(a, b):
    real(a, b)
    renames[0] += 1
    if renames[0] == int(sys.argv[2]):
        os.kill(os.getpid(), signal.SIGKILL)

files.os.replace = replace_then_die
files.replace_directory(sys.argv[1], lambda d: (d / "run.json").write_text("new"))
"""


def _old_run(tmp_path: Path) -> Path:
    target = tmp_path / "runs" / "x"
    target.mkdir(parents=True)
    (target / "run.json").write_text("old")
    return target


@pytest.mark.parametrize("killed_after, holds", [(1, "old"), (2, "new")])
def test_a_swap_killed_between_its_renames_leaves_one_whole_directory(tmp_path, killed_after, holds):
    target = _old_run(tmp_path)
    proc = subprocess.run([sys.executable, "-c", KILLED_SWAP, str(target), str(killed_after)],
                          env=os.environ | {"PYTHONPATH": str(SRC)}, capture_output=True)
    assert proc.returncode == -9, proc.stderr           # killed, as planned
    restore_directory(target)
    assert (target / "run.json").read_text() == holds
    assert sorted(p.name for p in target.parent.iterdir()) == ["x"]        # nothing left beside it
    # the next swap goes through as usual
    replace_directory(target, lambda d: (d / "run.json").write_text("newer"))
    assert (target / "run.json").read_text() == "newer"


def test_a_failed_build_keeps_the_old_directory(tmp_path):
    target = _old_run(tmp_path)

    def broken(d: Path) -> None:
        (d / "half.json").write_text("{")
        raise RuntimeError("disk full")

    with pytest.raises(RuntimeError, match="disk full"):
        replace_directory(target, broken)
    assert (target / "run.json").read_text() == "old"
    assert sorted(p.name for p in target.parent.iterdir()) == ["x"]       # nothing left beside it


def test_a_foreign_file_by_the_set_aside_name_is_refused_and_kept(tmp_path):
    """A file of someone else's named like the old directory's place aside (``.x.old``) stops the
    swap with a message naming it, before anything moves; the run and the file are untouched."""
    target = _old_run(tmp_path)
    foreign = target.with_name(".x.old")
    foreign.write_text("not simgap's")
    with pytest.raises(InputError, match=r"\.x\.old.*remove or rename"):
        replace_directory(target, lambda d: (d / "run.json").write_text("new"))
    assert (target / "run.json").read_text() == "old"
    assert foreign.read_text() == "not simgap's"
    assert sorted(p.name for p in target.parent.iterdir()) == [".x.old", "x"]


def test_a_swapped_in_directory_has_the_permissions_of_the_umask(tmp_path):
    previous = os.umask(0o022)
    try:
        replace_directory(tmp_path / "run", lambda tmp: (tmp / "run.json").write_text("{}"))
    finally:
        os.umask(previous)
    assert (tmp_path / "run").stat().st_mode & 0o777 == 0o755


def test_files_built_in_a_staged_directory_are_published_whole_and_the_rest_removed(tmp_path):
    with staged_directory(tmp_path, "export") as staged:
        (staged / "road.xodr").write_text("<road/>")
        (staged / "scene.xosc").write_text("<scene/>")
        (staged / "scratch.txt").write_text("not published")
        published = publish(staged, tmp_path / "out", ["road.xodr", "scene.xosc"])
    assert published == [tmp_path / "out" / "road.xodr", tmp_path / "out" / "scene.xosc"]
    assert sorted(p.name for p in tmp_path.rglob("*")) == ["out", "road.xodr", "scene.xosc"]


def test_a_staged_directory_a_killed_writer_left_is_removed_by_the_next_of_its_name(tmp_path):
    left = tmp_path / ".export.abc123.tmp"            # a writer SIGKILLed mid-export left it
    left.mkdir()
    (left / "road.xodr").write_text("<half")
    other = tmp_path / ".other.abc123.tmp"
    other.mkdir()
    with staged_directory(tmp_path, "export") as staged:
        assert not left.exists() and other.exists()
        (staged / "road.xodr").write_text("<road/>")
        publish(staged, tmp_path, ["road.xodr"])
    assert sorted(p.name for p in tmp_path.iterdir()) == [".other.abc123.tmp", "road.xodr"]
