"""What recorded CommonRoad files carry and a run must respect, written to XML and run from the file
as a user would: the ego's own recorded vehicle beside its planning problem (converted datasets keep
the human driver in the scenario), and planning problems that start when their vehicle enters the
road, later than the scenario."""

from __future__ import annotations

import json

import numpy as np
import pytest
from commonroad.planning.planning_problem import PlanningProblem, PlanningProblemSet
from commonroad.scenario.state import InitialState
from real_like import box_goal, highway, lane_y, lanelet_goal, recorded_car, run_ego, start

from simgap.cosim import CosimSettings
from simgap.experiment.single_run import RunRequest, execute
from simgap.record import read_run
from simgap.scenario.files import write_xml


def test_the_agents_own_recorded_vehicle_is_not_traffic(tmp_path):
    # the recorded human (obstacle 500) starts exactly where the planning problem starts: left in the
    # traffic it would overlap the agent from t = 0
    scenario = highway(lanes=1, length=300, segments=1)
    scenario.add_objects(recorded_car(500, 10.0, 0, 10.0, 150))
    scenario.add_objects(recorded_car(501, 80.0, 0, 12.0, 150))      # a real road user ahead
    problems = PlanningProblemSet([PlanningProblem(1, start(10, 0, 10.0), box_goal(200, 0, (0, 150)))])
    xml = tmp_path / "recorded.xml"
    write_xml(scenario, problems, xml)
    run = execute(RunRequest(scenario=xml))
    (agent,) = run.agents
    assert agent.history.outcome == "goal_reached", [e.detail for e in run.history.events]
    assert agent.recorded_as == 500
    assert agent.evaluation.min_distance_to_traffic_m > 1.0          # measured to 501, not to its own recording


def late_entry(tmp_path):
    """Agent 2 starts at 6 s at x = 60 m, where a recorded car (600) passes at 2-3 s: present from the
    start, it would be hit there; its own recording (601) enters the road with it and is not traffic;
    agent 1 drives from the start in the next lane."""
    scenario = highway(lanes=2, length=400, segments=1)
    scenario.add_objects(recorded_car(600, 30.0, 0, 12.0, 250))
    late = InitialState(position=np.array([60.0, lane_y(0)]), orientation=0.0, velocity=8.0, acceleration=0.0,
                        yaw_rate=0.0, slip_angle=0.0, time_step=60)
    own = recorded_car(601, 60.0, 0, 8.0, 200)
    own.initial_state.time_step = 60
    for k, state in enumerate(own.prediction.trajectory.state_list):
        state.time_step = 61 + k
    scenario.add_objects(own)
    problems = PlanningProblemSet([PlanningProblem(1, start(100, 1, 5.0), box_goal(300, 1, (0, 400))),
                                   PlanningProblem(2, late, box_goal(200, 0, (60, 400)))])
    xml = tmp_path / "late.xml"
    write_xml(scenario, problems, xml)
    return xml


@pytest.mark.parametrize("world", ["ideal", "mujoco"])
def test_a_planning_problem_that_starts_later_enters_the_road_then(tmp_path, world):
    run = execute(RunRequest(scenario=late_entry(tmp_path), backend=world))
    outcomes = {a.id: a for a in run.agents}
    for aid in (1, 2):
        assert outcomes[aid].history.outcome == "goal_reached", [e.detail for e in run.history.events if e.agent_id == aid]
    assert outcomes[2].recorded_as == 601
    late_driven = run.history.driven[2]
    assert late_driven.t[0] == pytest.approx(6.0)
    assert (late_driven.x[0], late_driven.y[0]) == pytest.approx((60.0, lane_y(0)), abs=0.02)
    assert late_driven.v[0] == pytest.approx(8.0, abs=0.2)
    assert not [e for e in run.history.events if e.agent_id == 2 and e.t < 6.0]


def test_a_run_that_ends_before_an_agent_enters_records_it_where_it_would_start(tmp_path):
    # (as two files of the recorded corpus do: agents that enter after the run's end)
    run = execute(RunRequest(scenario=late_entry(tmp_path), cosim=CosimSettings(max_time_s=3.0)), tmp_path / "run")
    waiting = run.history.agent(2)
    assert waiting.outcome == "timeout" and waiting.observed is None and waiting.plans == ()
    assert len(waiting.driven) == 1 and waiting.driven.t[0] == pytest.approx(6.0)
    again = read_run(tmp_path / "run")
    assert again.history == run.history and again.settings == run.settings
    # (its tracking and lateral offsets are NaN: no route from where it never started; NaN is no equal of NaN)
    assert json.dumps(again.summary()) == json.dumps(run.summary())
    skipped = [c for c in run.evaluation.criticality if c.ego_id == 2]      # it never moved: nothing to measure
    assert skipped and all(c.at_t is None and c.skipped_steps > 0 for c in skipped)


def test_a_start_in_a_gap_between_lanelets_runs_without_a_traceback(tmp_path):
    # recorded maps leave centimetre gaps where lanelets meet at an intersection's entry; a start in
    # one lies on no lanelet (the route planner finds no initial lanelet): the route starts from the
    # nearest lanelet heading the same way, for the planner and for the run's metrics alike
    from commonroad.scenario.lanelet import Lanelet, LaneletNetwork
    from commonroad.scenario.scenario import Scenario

    def straight(lid: int, x0: float, x1: float, successor=None, predecessor=None) -> Lanelet:
        x = np.linspace(x0, x1, 12)
        return Lanelet(np.stack([x, np.full_like(x, 3.5)], 1), np.stack([x, np.full_like(x, 1.75)], 1),
                       np.stack([x, np.zeros_like(x)], 1), lid, successor=successor, predecessor=predecessor)

    scenario = Scenario(0.1)
    scenario.add_objects(LaneletNetwork.create_from_lanelet_list(
        [straight(1, 0.0, 50.0, successor=[2]), straight(2, 50.04, 150.0, predecessor=[1])]))
    initial = start(50.02, 0, 6.0)
    assert not scenario.lanelet_network.find_lanelet_by_position([initial.position])[0]
    problems = PlanningProblemSet([PlanningProblem(1, initial, box_goal(120, 0, (0, 200)))])
    xml = tmp_path / "gap.xml"
    write_xml(scenario, problems, xml)
    run = execute(RunRequest(scenario=xml), out=tmp_path / "run")
    (agent,) = run.agents
    assert agent.history.outcome == "goal_reached", [e.detail for e in run.history.events]
    assert run.evaluation.metrics                          # the run metrics found the route too


def test_a_recorded_vehicle_running_into_the_waiting_ego_says_so():
    # one lane; the ego waits for its goal's time window; a car recorded at 15 m/s comes from behind
    # and, replayed, does not brake: the collision is the other's, and the reason says so
    scenario = highway(lanes=1, length=300, segments=1)
    scenario.add_objects(recorded_car(700, -40, 0, 15.0, 300))
    run = run_ego(scenario, start(40, 0, 0.0), box_goal(46, 0, (150, 200)))
    (agent,) = run.agents
    (event,) = [e for e in run.history.events if e.kind == "collision"]
    assert agent.history.outcome == "collision" and event.other_id == 700
    assert event.detail.startswith("rear-ended by recorded road user 700 (15.0 m/s) while the ego was ")
    assert "replayed traffic does not brake for the ego" in event.detail


def test_highway_speed_with_a_car_beside_the_lane_change():
    # 36 m/s with the goal one lane to the left and a recorded car beside the ego in that lane at the
    # same speed: the lane change needs a clearly lower (or higher) speed, which the end speeds reach
    scenario = highway(lanes=2, length=900, segments=1)
    scenario.add_objects(recorded_car(800, 12.0, 1, 36.0, 250))
    scenario.add_objects(recorded_car(801, 120.0, 0, 33.0, 250))
    run = run_ego(scenario, start(10, 0, 36.0), lanelet_goal(scenario, 20, (0, 250)))
    (agent,) = run.agents
    assert agent.history.outcome == "goal_reached", [e.detail for e in run.history.events]
    assert agent.history.planner_failures == 0 and agent.evaluation.min_distance_to_traffic_m > 0.0
