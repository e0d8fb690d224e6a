"""A report or a picture is written whole or not at all: a report build that dies half-way
leaves the previous report (or none) and the next build needs no --overwrite; a corrupt run
leaves no empty picture folder."""

from __future__ import annotations

import errno
import shutil
import subprocess
import sys

import pytest

import simgap.report.site as site
from simgap.cli.outputs import check_report_out
from simgap.cosim import CosimSettings
from simgap.errors import InputError
from simgap.experiment.single_run import RunRequest, execute
from simgap.report.scene2d import render_run
from simgap.scenario import build_scenario
from simgap.scenario.files import write_scenario


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    root = tmp_path_factory.mktemp("written-whole")
    xml = write_scenario(build_scenario("curve", {"radius": 40, "angle": 30}), root / "scenarios", preview=False)
    execute(RunRequest(scenario=xml, cosim=CosimSettings(replan_every=3, max_time_s=4.0), validate=False),
            root / "runs" / xml.stem / "ideal")
    return root / "runs"


def test_a_report_build_that_dies_half_way_leaves_the_previous_report(runs, tmp_path, monkeypatch):
    out = tmp_path / "report"
    first = site.build_report(runs, out).read_text()
    page = site.page

    def die_at_the_index(path, *args):
        if path.name == "index.html":
            raise KeyboardInterrupt            # the user's Ctrl-C, after the assets and scenario pages
        return page(path, *args)

    monkeypatch.setattr(site, "page", die_at_the_index)
    with pytest.raises(KeyboardInterrupt):
        site.build_report(runs, out)
    with pytest.raises(KeyboardInterrupt):
        site.build_report(runs, tmp_path / "new")
    monkeypatch.setattr(site, "page", page)
    assert (out / "index.html").read_text() == first
    assert sorted(p.name for p in tmp_path.iterdir()) == ["report"]      # no half report, no temporaries
    check_report_out(out, overwrite=False)                               # the next build may replace it
    assert site.build_report(runs, out).read_text() == first


def test_a_report_is_refused_where_it_would_replace_what_it_did_not_write(runs, tmp_path):
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "notes.txt").write_text("mine")
    with pytest.raises(InputError, match="holds notes.txt, not a simgap report"):
        check_report_out(mine, overwrite=False)
    with pytest.raises(InputError, match="would replace the runs it draws"):
        site.build_report(runs, runs.parent)
    assert (mine / "notes.txt").read_text() == "mine"


def test_a_corrupt_run_leaves_no_picture_folder(runs, tmp_path):
    corrupt = tmp_path / "corrupt"
    shutil.copytree(next(runs.rglob("run.json")).parent, corrupt)
    (corrupt / "run.json").write_text("{cut short")
    with pytest.raises(InputError, match="cannot read the run's record") as err:
        render_run(corrupt, tmp_path / "pictures")
    assert err.value.file == str(corrupt / "run.json")
    assert not (tmp_path / "pictures").exists()


FILE_LIMITED = '''
import resource, signal, sys
from pathlib import Path
import numpy as np
signal.signal(signal.SIGXFSZ, signal.SIG_IGN)        # a write past the limit fails (EFBIG), as on a full disk
resource.setrlimit(resource.RLIMIT_FSIZE, (int(sys.argv[1]), int(sys.argv[1])))
from simgap.report.scene2d import render_run
from simgap.report.scene3d import write_video
try:
    if sys.argv[2] == "video":
        write_video(Path(sys.argv[3]) / "v.mp4", (np.random.default_rng(k).integers(0, 255, (240, 320, 3),
                    dtype=np.uint8) for k in range(20)), 10)
    else:
        render_run(sys.argv[2], sys.argv[3], animation=True)
except OSError as exc:
    print("OSError", exc.errno)
'''


def _file_limited(limit: int, *args) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", FILE_LIMITED, str(limit), *map(str, args)], capture_output=True,
                          text=True, timeout=300)


def test_an_animation_the_disk_cannot_hold_fails_once_and_leaves_nothing(runs, tmp_path):
    # imageio's writer flushed the GIF as it closed and again as it was collected: the second failure
    # reached the user as a traceback after simgap's one line
    whole = render_run(next(runs.glob("*/ideal")), tmp_path / "whole", animation=True)
    png, gif = (p.stat().st_size for p in whole)
    assert gif > png + 4096
    done = _file_limited(png + 1024, next(runs.glob("*/ideal")), tmp_path / "limited")
    assert done.stdout.split() == ["OSError", str(errno.EFBIG)]
    assert "Traceback" not in done.stderr and "Exception ignored" not in done.stderr
    assert sorted(p.name for p in (tmp_path / "limited").iterdir()) == ["scene.png"]


def test_a_video_ffmpeg_could_not_finish_is_an_error_not_a_short_file(tmp_path):
    done = _file_limited(64 * 1024, "video", tmp_path)
    assert done.stdout.split() == ["OSError", str(errno.EIO)]     # not ENOSPC: this disk has room
    assert done.stderr == ""                                       # nor ffmpeg's own lines
    assert list(tmp_path.iterdir()) == []
