"""A scenario on an OpenDRIVE road: the start and goal given by lane or by point, refused clearly
when they name no driving lane or the goal is not ahead, written with a sidecar that keeps where
the lanelets came from."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from simgap.errors import InputError
from simgap.scenario import load_scenario, read_sidecar, write_scenario
from simgap.scenario.opendrive.network import opendrive_network
from simgap.scenario.opendrive.scenario import opendrive_scenario

ROADS = Path(__file__).parent / "opendrive_roads"
JUNCTION = ROADS / "fabriksgatan.xodr"


@pytest.fixture(scope="module")
def junction():
    return opendrive_network(JUNCTION)


def test_a_start_and_goal_by_lane_make_one_planning_problem_on_those_lanes(junction):
    concrete = opendrive_scenario(JUNCTION, "2:-1:270", "3:1:80", {"initial_speed": "5", "time_limit": "30"},
                                  roads=junction)
    (problem,) = concrete.problems.planning_problem_dict.values()
    start = junction.lanelets.find_lanelet_by_position([problem.initial_state.position])[0]
    assert {(junction.origin.lanelets[i].road, junction.origin.lanelets[i].lane) for i in start} == {("2", -1)}
    assert problem.initial_state.velocity == 5.0
    (goal,) = problem.goal.state_list
    assert goal.time_step.end == 300
    centre = goal.position.center
    assert {(junction.origin.lanelets[i].road, junction.origin.lanelets[i].lane)
            for i in junction.lanelets.find_lanelet_by_position([centre])[0]} == {("3", 1)}
    assert concrete.parameters | {} == {"source": "fabriksgatan.xodr", "start": "2:-1:270", "goal": "3:1:80",
                                        "initial_speed": 5.0, "time_limit": 30.0, "dt": 0.1}


def test_points_name_the_driving_lane_under_them(junction):
    by_lane = opendrive_scenario(JUNCTION, "2:-1:270", "3:1:80", roads=junction)
    (problem,) = by_lane.problems.planning_problem_dict.values()
    start = problem.initial_state.position
    goal = problem.goal.state_list[0].position.center
    by_point = opendrive_scenario(JUNCTION, f"{start[0]},{start[1]}", f"{goal[0]},{goal[1]}", roads=junction)
    (again,) = by_point.problems.planning_problem_dict.values()
    assert np.allclose(again.initial_state.position, start, atol=1e-6)
    assert again.initial_state.orientation == pytest.approx(problem.initial_state.orientation, abs=1e-6)
    assert np.allclose(again.goal.state_list[0].position.center, goal, atol=1e-6)


@pytest.mark.parametrize("start, goal, field, fragments", [
    ("99:-1:10", "3:1:80", "--start", ["road '99' has no driving lane", "roads 0, 1, 2, 3"]),
    ("2:-3:10", "3:1:80", "--start", ["lane -3 of road 2 is no driving lane", "lanes -1, 1 of road 2"]),
    ("2:-1:400", "3:1:80", "--start", ["station 400 m is not on lane -1", "0.0 to 304.2 m"]),
    ("2:-1:270", "500,500", "--goal", ["on no driving lane"]),
    ("2:-1:270", "2:1:100", "--goal", ["not ahead of the start"]),
    ("2:-1:270", "2:-1:200", "--goal", ["not ahead of the start"]),
    ("2:-1", "3:1:80", "--start", ["names no place", "ROAD:LANE:S"]),
])
def test_places_that_name_no_reachable_driving_lane_are_refused(junction, start, goal, field, fragments):
    with pytest.raises(InputError) as refused:
        opendrive_scenario(JUNCTION, start, goal, roads=junction)
    assert refused.value.field == field
    for fragment in fragments:
        assert fragment in refused.value.describe()


def test_settings_are_checked_by_name_and_range(junction):
    with pytest.raises(InputError, match="--set.speed"):
        opendrive_scenario(JUNCTION, "2:-1:270", "3:1:80", {"speed": "3"}, roads=junction)
    with pytest.raises(InputError, match="--set.initial_speed"):
        opendrive_scenario(JUNCTION, "2:-1:270", "3:1:80", {"initial_speed": "-1"}, roads=junction)


def test_the_written_scenario_reloads_with_its_sections_and_origin(tmp_path):
    concrete = opendrive_scenario(ROADS / "crest-curve.xodr", "0:-1:180", "0:-1:290")
    xml = write_scenario(concrete, tmp_path, preview=False)
    scenario, problems = load_scenario(xml)
    assert len(scenario.lanelet_network.lanelets) == 4 and len(problems.planning_problem_dict) == 1
    meta = read_sidecar(xml)
    assert meta.logical == "opendrive" and set(meta.sections.kinds.values()) == {"straight", "clothoid"}
    origin = meta.opendrive
    assert origin == concrete.opendrive and origin.source == "crest-curve.xodr"
    assert set(origin.profiles) == {"0"} and origin.profiles["0"].elevation[1].c == pytest.approx(0.00367346938776)
    assert read_sidecar(write_scenario(_generated(), tmp_path / "g", preview=False)).opendrive is None


def _generated():
    from simgap.scenario import build_scenario

    return build_scenario("curve", {"radius": 20})
