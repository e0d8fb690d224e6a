"""A planner in simgap's own process cannot move the run or end simgap silently: its os.chdir
leaves the run where it was asked for, its os._exit fails its cycles, a segfault is said."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from simgap.experiment.single_run import RunRequest, execute
from simgap.planning.registry import PlannerChoice
from simgap.scenario import build_scenario
from simgap.scenario.files import write_scenario

PLANNERS = '''
import ctypes
import os

from simgap.planning.idm_planner import IdmPlanner


class Wanderer(IdmPlanner):
    def plan(self, observed, t, world):
        os.chdir(os.environ["WANDER_TO"])
        return super().plan(observed, t, world)


class Leaver(IdmPlanner):
    def plan(self, observed, t, world):
        if t > 0.25:
            os._exit(0)
        return super().plan(observed, t, world)


class Crasher(IdmPlanner):
    def plan(self, observed, t, world):
        if t > 0.25:
            ctypes.string_at(0)
        return super().plan(observed, t, world)
'''


@pytest.fixture(scope="module")
def curve_xml(tmp_path_factory) -> Path:
    return write_scenario(build_scenario("curve", {"radius": 30.0, "angle": 45.0}), tmp_path_factory.mktemp("curve"),
                          preview=False)


@pytest.fixture
def planners(tmp_path) -> Path:
    path = tmp_path / "hostile_planners.py"
    path.write_text(PLANNERS)
    return path


def test_a_planner_that_changes_folder_moves_no_output(curve_xml, planners, tmp_path, monkeypatch):
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.setenv("WANDER_TO", str(elsewhere))
    monkeypatch.chdir(tmp_path)
    run = execute(RunRequest(scenario=curve_xml, planner=PlannerChoice(planner=f"{planners}:Wanderer")), Path("r"))
    assert run.agents[0].history.outcome == "goal_reached"
    assert (tmp_path / "r" / "run.json").is_file() and not (elsewhere / "r").exists()
    assert Path.cwd() == tmp_path, "simgap is back in its folder"


def test_a_planner_that_calls_os_exit_fails_its_cycles_and_the_run_is_written(curve_xml, planners, tmp_path):
    run = execute(RunRequest(scenario=curve_xml, planner=PlannerChoice(planner=f"{planners}:Leaver")),
                  tmp_path / "r")
    assert run.agents[0].history.outcome == "planner_failure"
    assert any("os._exit(0) would have ended simgap's process" in e.message for e in run.history.planner_errors)
    assert json.loads((tmp_path / "r" / "run.json").read_text())["history"]["agents"][0]["outcome"] == \
        "planner_failure"


def test_a_planner_that_crashes_the_interpreter_is_named_in_what_simgap_says(curve_xml, planners, tmp_path):
    done = subprocess.run([sys.executable, "-m", "simgap", "run", str(curve_xml), "--out", str(tmp_path / "r"),
                           "--no-validate", "--planner", f"{planners}:Crasher"], capture_output=True, text=True,
                          timeout=120, env={**os.environ, "PYTHONFAULTHANDLER": ""})
    assert done.returncode != 0
    assert "Segmentation fault" in done.stderr and "hostile_planners.py" in done.stderr
