"""`simgap generate` and `simgap export` follow the rule of `run`, `report`, `render` and
`experiment`: a folder they did not write, and a file of the user's by a name they would write,
are refused in one line before any work (exit 2, the file untouched) unless --overwrite; their own
folder they write into again."""

from __future__ import annotations

import os
import subprocess

import pytest
import simgap_command
from typer.testing import CliRunner

from simgap.cli.outputs import check_files_out, files_out
from simgap.errors import InputError
from simgap.scenario import load_logical, write_scenario


def simgap(*args) -> subprocess.CompletedProcess:
    return simgap_command.simgap(*args, env=dict(os.environ, COLUMNS="200"))


def refused(proc: subprocess.CompletedProcess, *fragments: str) -> bool:
    lines = proc.stderr.strip().splitlines()
    return proc.returncode == 2 and len(lines) == 1 and all(f in lines[0] for f in fragments)


def test_generate_refuses_the_users_folder_and_file_and_writes_its_own_again(tmp_path):
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "curve_radius-50_angle-30.xml").write_text("mine")
    pin = ["--set", "radius=50", "--set", "angle=30", "--no-preview"]
    assert refused(simgap("generate", "curve", *pin, "--out", mine), "curve_radius-50_angle-30.xml",
                   "simgap generate did not write", "--overwrite")
    assert (mine / "curve_radius-50_angle-30.xml").read_text() == "mine"
    assert refused(simgap("generate", "curve", *pin, "--out", "/"), "/: holds", "--overwrite")

    ours = tmp_path / "scenarios"
    for _ in range(2):                                     # its own folder, again
        assert simgap("generate", "curve", *pin, "--out", ours).returncode == 0
    (ours / "curve_radius-60_angle-30.xml").write_text("mine")      # a file of the user's in it
    again = simgap("generate", "curve", "--set", "radius=60", "--set", "angle=30", "--no-preview", "--out", ours)
    assert refused(again, "curve_radius-60_angle-30.xml", "simgap generate did not write")
    assert (ours / "curve_radius-60_angle-30.xml").read_text() == "mine"
    forced = simgap("generate", "curve", *pin, "--out", mine, "--overwrite")
    assert forced.returncode == 0 and "commonRoad" in (mine / "curve_radius-50_angle-30.xml").read_text()


def test_export_refuses_the_users_folder_and_writes_its_own_again(tmp_path):
    scenario = write_scenario(load_logical("curve").build({"radius": 50, "angle": 30}), tmp_path, preview=False)
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "base.xml").write_text("mine")
    assert refused(simgap("export", scenario, "--out", mine), "base.xml", "simgap export did not write")
    assert sorted(p.name for p in mine.iterdir()) == ["base.xml"]
    ours = tmp_path / "exported"
    for _ in range(2):
        proc = simgap("export", scenario, "--out", ours)
        assert proc.returncode == 0, proc.stderr
    assert [p.name for p in ours.iterdir() if not p.name.startswith(".")] == [f"{scenario.stem}.xodr"]


def test_a_command_that_fails_leaves_no_folder_and_its_cut_short_folder_is_its_own(tmp_path):
    out = tmp_path / "new"
    with pytest.raises(InputError):
        with files_out(out, "export", [], overwrite=False):
            raise InputError("the work failed")
    assert not out.exists()
    with pytest.raises(KeyboardInterrupt):
        with files_out(out, "generate", ["a.xml"], overwrite=False):
            (out / "a.xml").write_text("half")
            raise KeyboardInterrupt
    check_files_out(out, "generate", ["a.xml"], overwrite=False)          # the rerun may write it again
    with pytest.raises(InputError, match="a.xml, which simgap export did not write"):
        check_files_out(out, "export", [], overwrite=False)


def test_knobs_a_run_would_drop_or_that_are_given_twice_are_refused(tmp_path):
    import simgap.cli.run  # noqa: F401  (registers the command)
    from simgap.cli.main import app

    scenario = write_scenario(load_logical("curve").build({"radius": 50, "angle": 30}), tmp_path, preview=False)
    run = ["run", str(scenario), "--backend", "dynamic", "--no-validate", "--out", str(tmp_path / "r")]
    for knobs, field, reason in (
            (["--realism", "ideal", "--knob", "steer_delay=0.1", "--knob", "position_drift=10"], "knob position_drift",
             "does not apply under realism ideal"),
            (["--knob", "latency=1", "--knob", "latency=0.5"], "knob latency", "given twice")):
        error = CliRunner().invoke(app, run + knobs).exception          # (the command prints it in one line, exit 2)
        assert isinstance(error, InputError) and error.field == field and reason in error.reason
    assert not (tmp_path / "r").exists()
