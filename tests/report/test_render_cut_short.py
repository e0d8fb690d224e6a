"""`simgap render` cut short (a full disk, a kill) leaves a folder its rerun draws into again,
never pictures the rerun refuses as not its own; a run it cannot draw leaves no folder."""

from __future__ import annotations

import errno
import shutil
from pathlib import Path

from typer.testing import CliRunner

import simgap.cli.render  # noqa: F401  (registers the command)
from simgap.cli.main import app
from simgap.errors import InputError
from simgap.files import atomic_write
from simgap.report import scene2d

IDEAL_RUN = next(p.parent for p in (Path(__file__).parents[1] / "data" / "format1-study" / "runs").rglob("run.json")
                 if p.parent.name == "ideal")


def test_a_render_cut_short_by_a_full_disk_is_drawn_again_by_its_rerun(tmp_path, monkeypatch):
    run, pictures = Path(shutil.copytree(IDEAL_RUN, tmp_path / "run")), tmp_path / "pictures"

    def full_disk(run_dir, out, frame_every, on_frame):  # the first picture drawn, then the disk is full
        atomic_write(Path(out) / scene2d.PICTURES[0], lambda tmp: tmp.write_bytes(b"a whole picture"))
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(scene2d, "render_run", full_disk)
    cut = CliRunner().invoke(app, ["render", str(run), "--out", str(pictures), "--frame-every", "40"])
    assert isinstance(cut.exception, OSError) and cut.exception.errno == errno.ENOSPC
    assert not [p for p in pictures.iterdir() if p.name.startswith(".")]          # no temporary left
    monkeypatch.undo()
    again = CliRunner().invoke(app, ["render", str(run), "--out", str(pictures), "--frame-every", "40"])
    assert again.exit_code == 0, again.output
    assert (pictures / "scene.png").read_bytes()[:4] == b"\x89PNG" and (pictures / "run.gif").is_file()


def test_a_run_that_cannot_be_drawn_leaves_no_folder(tmp_path):
    run = Path(shutil.copytree(IDEAL_RUN, tmp_path / "run"))
    (run / "run.json").write_text("null")
    refused = CliRunner().invoke(app, ["render", str(run), "--out", str(tmp_path / "pictures")])
    assert isinstance(refused.exception, InputError) and refused.exception.file == str(run / "run.json")
    assert not (tmp_path / "pictures").exists()
