"""One agent placed on a map by a start and a goal point (`simgap.scenario.placement`): on the lane
under the start, heading along it (or as told), its goal ahead along the lanes' links; what is not
a place on the map is refused naming the option and what is allowed."""

from __future__ import annotations

import math

import pytest
from shapely.geometry import Point

from simgap.errors import InputError
from simgap.scenario import build_scenario
from simgap.scenario.goal import area_of
from simgap.scenario.placement import AgentPlacement


@pytest.fixture(scope="module")
def curve():
    """A 100 m straight, then a 90° curve: lanelet 100 eastbound at y = -1.5, 105 westbound at 1.5."""
    return build_scenario("curve", {}).scenario


def _placed(scenario, start: str, goal: str):
    (problem,) = AgentPlacement.of_options(start, goal).planning_problems(scenario).planning_problem_dict.values()
    return problem


def test_the_start_is_on_the_lane_centre_heading_along_it_and_the_goal_a_box_there(curve):
    problem = _placed(curve, "20,-1", "80,-1.5")
    assert problem.planning_problem_id == 1
    assert problem.initial_state.position == pytest.approx([20.0, -1.5], abs=1e-6)
    assert problem.initial_state.orientation == pytest.approx(0.0, abs=1e-6)
    assert problem.initial_state.velocity == 0.0
    goal = area_of(problem.goal.state_list[0].position)
    assert goal.contains(Point(80, -1.5)) and goal.bounds[2] - goal.bounds[0] == pytest.approx(10.0, abs=0.01)


def test_a_heading_and_a_goal_radius_are_taken_as_given(curve):
    problem = _placed(curve, " 20,-1.5,30 ", "80,-1,4")
    assert problem.initial_state.orientation == pytest.approx(math.radians(30))
    goal = area_of(problem.goal.state_list[0].position)
    assert goal.centroid.distance(Point(80, -1)) < 1e-6 and goal.area == pytest.approx(math.pi * 16, rel=0.01)


@pytest.mark.parametrize("start, goal, field, words", [
    ("80,-1.5", "20,-1.5", "--goal", "not ahead of the start"),            # behind
    ("20,1.5", "80,1.5", "--goal", "not ahead of the start"),              # the westbound lane leads away
    ("20,30", "80,-1.5", "--start", "is on no driving lane"),
    ("20", "80,-1.5", "--start", "is not a point"),
    ("20,north", "80,-1.5", "--start", "is not numbers"),
    ("20,-1.5", "80,-1.5,0", "--goal", "a goal radius of 0 m"),
    ("20,-1.5", "80,-1.5,nan", "--goal", "is not finite"),
])
def test_what_is_no_place_ahead_is_refused_naming_the_option(curve, start, goal, field, words):
    with pytest.raises(InputError, match=words) as refused:
        _placed(curve, start, goal)
    assert refused.value.field == field and refused.value.allowed


def test_a_start_without_a_goal_is_refused_and_neither_places_nothing():
    assert AgentPlacement.of_options(None, None) is None
    with pytest.raises(InputError, match="--start needs --goal too") as refused:
        AgentPlacement.of_options("20,-1.5", None)
    assert refused.value.field == "--goal" and "RADIUS" in refused.value.allowed
