"""`simgap generate ROAD.xodr --start --goal`: a scenario on a public OpenDRIVE road, run to its
goal in the ideal and the MuJoCo world by one command each; what cannot be read is refused in one
line with exit code 2."""

from __future__ import annotations

import json
import os
import subprocess
from pathlib import Path

import pytest
import simgap_command

ROADS = Path(__file__).parents[1] / "scenario" / "opendrive_roads"


def simgap(*args: str) -> subprocess.CompletedProcess:
    return simgap_command.simgap(*args, env=dict(os.environ, COLUMNS="160"))


@pytest.fixture(scope="module")
def junction_scenario(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("scenarios")
    made = simgap("generate", str(ROADS / "fabriksgatan.xodr"), "--start", "2:-1:270", "--goal", "3:1:80",
                  "--out", str(out))
    assert made.returncode == 0, made.stderr
    assert "20 lanelets from fabriksgatan.xodr" in made.stdout
    assert sorted(p.name for p in out.iterdir()) == [".simgap-generate.json", "fabriksgatan.json", "fabriksgatan.png",
                                                     "fabriksgatan.xml"]
    return out / "fabriksgatan.xml"


@pytest.mark.slow
@pytest.mark.parametrize("backend", ["ideal", "mujoco"])
def test_a_left_turn_through_an_opendrive_junction_reaches_its_goal(junction_scenario, backend, tmp_path):
    run = simgap("run", str(junction_scenario), "--backend", backend, "--no-validate", "--json", "--out",
                 str(tmp_path / backend))
    assert run.returncode == 0, run.stderr
    (agent,) = json.loads(run.stdout)["agents"]
    assert agent["outcome"] == "goal_reached"


@pytest.mark.parametrize("args, fragments", [
    (["--start", "2:-1:270"], ["an OpenDRIVE road needs --goal"]),
    (["--start", "2:-1:270", "--goal", "1:1:5"], ["field '--goal'", "not ahead of the start"]),
    (["--start", "2:-1:270", "--goal", "3:1:80", "--set", "lanes=2"], ["field '--set.lanes'"]),
])
def test_generate_on_an_opendrive_road_refuses_what_places_no_agent(tmp_path, args, fragments):
    proc = simgap("generate", str(ROADS / "fabriksgatan.xodr"), *args, "--out", str(tmp_path / "out"))
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1, proc.stderr
    assert all(f in proc.stderr for f in fragments), proc.stderr
    assert not (tmp_path / "out").exists()


def test_an_element_simgap_does_not_read_is_refused_in_one_line(tmp_path):
    road = tmp_path / "road.xodr"
    road.write_text((ROADS / "crest-curve.xodr").read_text().replace("<line/>", "<cubicSpline/>", 1))
    proc = simgap("generate", str(road), "--start", "0:-1:10", "--goal", "0:-1:90", "--out", str(tmp_path / "out"))
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1, proc.stderr
    assert f"{road}: field 'road 0/planView/geometry/cubicSpline': <cubicSpline> on line 9" in proc.stderr
    assert "(allowed: line, arc, spiral, poly3, paramPoly3)" in proc.stderr


def test_start_and_goal_belong_to_an_opendrive_road(tmp_path):
    proc = simgap("generate", "curve", "--start", "1:-1:10", "--out", str(tmp_path))
    assert proc.returncode == 2 and "a .xodr file as LOGICAL" in proc.stderr
