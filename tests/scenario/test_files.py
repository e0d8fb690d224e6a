"""Reading scenario files: every bad file is refused with its name, the field and what is allowed."""

from __future__ import annotations

import numpy as np
import pytest
from commonroad.geometry.shape import Rectangle
from commonroad.planning.planning_problem import PlanningProblemSet
from commonroad.prediction.prediction import Occupancy, SetBasedPrediction, TrajectoryPrediction
from commonroad.scenario.lanelet import Lanelet, LaneletNetwork
from commonroad.scenario.obstacle import DynamicObstacle, ObstacleType, PhantomObstacle
from commonroad.scenario.scenario import Scenario
from commonroad.scenario.state import InitialState, LateralState
from commonroad.scenario.trajectory import Trajectory as CrTrajectory

from simgap.errors import InputError
from simgap.scenario import build_scenario, load_scenario
from simgap.scenario.files import write_xml
from simgap.scenario.obstacles import recorded_obstacles


def test_a_file_without_planning_problems_is_refused(tmp_path):
    concrete = build_scenario("curve", {"radius": 20, "angle": 45})
    path = tmp_path / "no-agents.xml"
    write_xml(concrete.scenario, PlanningProblemSet([]), path)
    with pytest.raises(InputError) as err:
        load_scenario(path)
    assert err.value.file == str(path) and err.value.field == "planningProblem"
    assert "no planning problems" in str(err.value)


@pytest.mark.parametrize("text", ["<commonRoad><oops", "not xml at all", ""])
def test_malformed_xml_is_refused(tmp_path, text):
    path = tmp_path / "broken.xml"
    path.write_text(text)
    with pytest.raises(InputError) as err:
        load_scenario(path)
    assert err.value.file == str(path) and "CommonRoad XML" in err.value.allowed


def test_a_file_of_an_older_commonroad_format_is_refused_naming_its_version(tmp_path):
    path = tmp_path / "GER_A9_2a.xml"
    path.write_text('<?xml version="1.0"?>\n<commonRoad commonRoadVersion="2017a" benchmarkID="GER_A9_2a"></commonRoad>')
    with pytest.raises(InputError) as err:
        load_scenario(path)
    assert err.value.file == str(path) and err.value.field == "commonRoadVersion"
    assert "format 2017a" in str(err.value) and "2018b or 2020a" in err.value.allowed


def test_an_obstacle_recorded_without_positions_is_refused_naming_it(tmp_path):
    # commonroad-io reads trajectories of lateral states (offset, heading, curvature), which place
    # nothing on the map
    concrete = build_scenario("curve", {"radius": 20, "angle": 45})
    shape = Rectangle(4.5, 1.8)
    initial = InitialState(time_step=0, position=np.array([5.0, 0.0]), orientation=0.0, velocity=5.0,
                           acceleration=0.0, yaw_rate=0.0, slip_angle=0.0)
    lateral = [LateralState(time_step=k, lateral_position=0.0, orientation=0.0, curvature=0.0, curvature_rate=0.0)
               for k in range(1, 4)]
    concrete.scenario.add_objects(DynamicObstacle(7, ObstacleType.CAR, shape, initial,
                                                  TrajectoryPrediction(CrTrajectory(1, lateral), shape)))
    path = tmp_path / "lateral.xml"
    write_xml(concrete.scenario, concrete.problems, path)
    with pytest.raises(InputError) as err:
        load_scenario(path)
    assert err.value.file == str(path) and err.value.field == "obstacle 7"
    assert "without a position (time step 1)" in str(err.value)


def test_a_phantom_obstacle_is_read_and_left_out_of_the_traffic(tmp_path):
    # an occluded road user that may be there (a set-based occupancy without an initial state)
    concrete = build_scenario("curve", {"radius": 20, "angle": 45})
    occupancy = [Occupancy(k, Rectangle(4.5, 1.8, np.array([20.0 + k, 0.0]))) for k in range(1, 4)]
    concrete.scenario.add_objects(PhantomObstacle(77, SetBasedPrediction(1, occupancy)))
    path = tmp_path / "phantom.xml"
    write_xml(concrete.scenario, concrete.problems, path)
    scenario, _ = load_scenario(path)
    assert [o.obstacle_id for o in scenario.phantom_obstacle] == [77]
    assert 77 not in {o.id for o in recorded_obstacles(scenario)}


def test_a_missing_file_is_refused(tmp_path):
    with pytest.raises(InputError, match="no such scenario file"):
        load_scenario(tmp_path / "missing.xml")


@pytest.mark.parametrize("dt", ["0", "-0.1", "nan", "inf", "1e-9", "3600"])
def test_a_time_step_no_scenario_can_have_is_refused(tmp_path, dt):
    concrete = build_scenario("curve", {"radius": 20, "angle": 45})
    path = tmp_path / "dt.xml"
    write_xml(concrete.scenario, concrete.problems, path)
    path.write_text(path.read_text().replace('timeStepSize="0.1"', f'timeStepSize="{dt}"'))
    with pytest.raises(InputError) as err:
        load_scenario(path)
    assert err.value.file == str(path) and err.value.field == "timeStepSize"
    assert err.value.allowed.startswith("0.01 to 10 s")


def _curve_xml_with(tmp_path, old: str, new: str):
    """The curve scenario's XML with the first ``old`` of its planning problem replaced by ``new``."""
    concrete = build_scenario("curve", {"radius": 20, "angle": 45})
    path = tmp_path / "curve.xml"
    write_xml(concrete.scenario, concrete.problems, path)
    text = path.read_text()
    start = text.index("<planningProblem")
    assert old in text[start:]
    path.write_text(text[:start] + text[start:].replace(old, new, 1))
    return path


VELOCITY = "<velocity>\n        <exact>0.0</exact>"
ORIENTATION = "<orientation>\n        <exact>0.0</exact>"


@pytest.mark.parametrize("old, new, field", [
    (VELOCITY, VELOCITY.replace("0.0", "nan"), "velocity"),
    (VELOCITY, VELOCITY.replace("0.0", "inf"), "velocity"),
    (VELOCITY, VELOCITY.replace("0.0", "-3"), "velocity"),
    (VELOCITY, VELOCITY.replace("0.0", "1e300"), "velocity"),
    (ORIENTATION, ORIENTATION.replace("0.0", "nan"), "orientation"),
    ("<time>\n        <exact>0</exact>", "<time>\n        <exact>700</exact>", "time"),   # the goal window ends at 600
])
def test_an_initial_state_no_vehicle_can_be_in_is_refused_naming_the_field(tmp_path, old, new, field):
    path = _curve_xml_with(tmp_path, old, new)
    with pytest.raises(InputError) as err:
        load_scenario(path)
    assert err.value.file == str(path) and err.value.field == f"planningProblem 1.initialState.{field}"


def test_a_lanelet_without_width_is_refused_naming_it(tmp_path):
    concrete = build_scenario("curve", {"radius": 20, "angle": 45})
    bound = np.array([[0.0, 50.0], [10.0, 50.0]])
    network = LaneletNetwork.create_from_lanelet_list(
        [*concrete.scenario.lanelet_network.lanelets, Lanelet(bound, bound.copy(), bound.copy(), 999)])
    scenario = Scenario(0.1)
    scenario.add_objects(network)
    path = tmp_path / "sliver.xml"
    write_xml(scenario, concrete.problems, path)
    with pytest.raises(InputError) as err:
        load_scenario(path)
    assert err.value.file == str(path) and err.value.field == "lanelet 999"
