"""Any map from the command line: `simgap maps` lists the installed real maps with a start and a
goal each, and `simgap run MAP --start X,Y --goal X,Y` drives one agent on a map that has no
planning problem to its goal."""

from __future__ import annotations

import json
import os
import re
import subprocess

import pytest
import simgap_command

from simgap.record import read_run
from simgap.scenario.real_maps import MAPS_PACKAGE, map_files, maps_dir

MAP = "USA_Intersection-1"


def simgap(*args: str, **env: str) -> subprocess.CompletedProcess:
    return simgap_command.simgap(*args, env=dict(os.environ, COLUMNS="250", **env))


@pytest.fixture(scope="module")
def real_map():
    found = {p.stem: p for p in map_files()}
    if MAP not in found:
        pytest.skip(f"{MAP} is not in {maps_dir()} (make install extracts the maps from {MAPS_PACKAGE})")
    return found[MAP]


def test_maps_lists_every_installed_map_and_a_start_and_goal_that_drive_one_to_its_goal(real_map, tmp_path):
    listed = simgap("maps")
    assert listed.returncode == 0, listed.stderr
    assert all(p.stem in listed.stdout for p in map_files()) and f"{len(map_files())} maps" in listed.stdout
    lines = listed.stdout.splitlines()
    at = next(i for i, line in enumerate(lines) if f" {MAP} " in line)       # its row: two lines
    start = re.search(r"--start (\S+)", lines[at]).group(1)
    goal = re.search(r"--goal (\S+)", lines[at + 1]).group(1)
    assert "drive one: simgap run " in listed.stdout
    out = tmp_path / "run"
    drove = simgap("run", str(real_map), "--start", start, "--goal", goal, "--out", str(out), "--no-validate",
                   "--json", "--fail-on", "off_road,collision,timeout")
    assert drove.returncode == 0, drove.stdout[-2000:] + drove.stderr
    assert json.loads(drove.stdout)["agents"][0]["outcome"] == "goal_reached"
    record = read_run(out)
    assert record.settings.parameters == {"start": start, "goal": goal}
    assert record.settings.scenario_path == str(real_map) and record.scenario_id == MAP


def test_a_map_without_planning_problems_says_how_to_place_an_agent(real_map, tmp_path):
    bare = simgap("run", str(real_map), "--out", str(tmp_path / "r"))
    assert bare.returncode == 2 and "no planning problems" in bare.stderr
    off = simgap("run", str(real_map), "--start", "1000,1000", "--goal", "0,0", "--out", str(tmp_path / "r"))
    assert off.returncode == 2 and "field '--start'" in off.stderr and "is on no driving lane" in off.stderr
    assert off.stderr.count("\n") == 1 and not (tmp_path / "r").exists()


def test_maps_without_maps_says_how_to_install_them(tmp_path):
    empty = simgap("maps", SIMGAP_REAL_MAPS=str(tmp_path))
    assert empty.returncode == 0 and "make install" in empty.stdout and str(tmp_path) in empty.stdout
