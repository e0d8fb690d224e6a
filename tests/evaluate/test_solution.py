"""Driven trajectories as CommonRoad solutions: the ideal run of a paper curve is a valid KS2
solution whose file commonroad-io reads back; the cost simgap reports for a recorded human
trajectory is CostFunctionEvaluator's own for the same solution file; an invalid solution says why
(and when); verdicts are cached by what was checked."""

from __future__ import annotations

import json
import os
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from commonroad.common.solution import CommonRoadSolutionReader, VehicleType
from commonroad.geometry.shape import Rectangle
from commonroad.planning.planning_problem import PlanningProblem, PlanningProblemSet
from commonroad.prediction.prediction import TrajectoryPrediction
from commonroad.scenario.obstacle import DynamicObstacle, ObstacleType
from commonroad.scenario.state import InitialState, KSState
from commonroad.scenario.trajectory import Trajectory as CrTrajectory
from commonroad_dc.costs.evaluation import CostFunctionEvaluator
from cosim.real_like import DT, box_goal, highway, lane_y, recorded_car, start

from simgap.cosim import AgentHistory, History, Outcome
from simgap.evaluate.settings import CostFunctionId
from simgap.evaluate.solution import cost_function_of, run_solution, solution_costs, solution_xml
from simgap.evaluate.solution_check import SolutionCheck, check_solution
from simgap.evaluate.validity import SolutionCheckCache, checked_solution
from simgap.experiment.single_run import RunRequest, execute
from simgap.scenario import build_scenario, load_scenario, write_scenario
from simgap.scenario.files import write_xml
from simgap.sim.protocol import Realism
from simgap.trajectory import Trajectory
from simgap.vehicles import load_vehicle

SEDAN = load_vehicle("sedan")


def paper_curve_xml(folder):
    return write_scenario(build_scenario("curve", {"radius": 10.0, "angle": 90.0}), folder, preview=False)


@pytest.fixture(scope="module")
def paper_curve_run(tmp_path_factory):
    folder = tmp_path_factory.mktemp("paper-curve")
    return execute(RunRequest(paper_curve_xml(folder), validate=True), folder / "run"), folder / "run"


def test_the_ideal_run_of_a_paper_curve_is_a_valid_ks2_sm1_solution(paper_curve_run):
    run, run_dir = paper_curve_run
    assert run.history.agents[0].outcome == Outcome.GOAL_REACHED
    agent = run.evaluation.agents[0]
    assert agent.solution_valid is True and agent.solution_reason == ""
    assert agent.solution_benchmark.startswith("KS2:SM1:")
    weights = {name: c.weight for name, c in agent.solution_partial_costs.items()}
    assert weights == {"A": 50.0, "SA": 50.0, "SR": 50.0, "L": 1.0, "V": 20.0, "O": 50.0}     # SM1's
    assert agent.solution_cost == pytest.approx(sum(c.weighted for c in agent.solution_partial_costs.values()))
    assert agent.solution_partial_costs["L"].cost == pytest.approx(agent.distance_m, abs=0.5)   # path length
    assert max(agent.solution_partial_costs.values(), key=lambda c: c.weighted) is \
        agent.solution_partial_costs["A"]         # starting from standstill, the acceleration dominates
    assert set(run.timings) == {"scoring", "io", "validation"}
    # the file commonroad-io reads back is the driven trajectory
    solution = CommonRoadSolutionReader.open(str(run_dir / "solution.xml"))
    assert solution.benchmark_id == agent.solution_benchmark
    states = solution.planning_problem_solutions[0].trajectory.state_list
    driven = run.history.driven[1]
    assert len(states) == len(driven)
    assert np.allclose([s.position for s in states], np.column_stack([driven.x, driven.y]))
    assert np.allclose([s.velocity for s in states], driven.v) and np.allclose([s.orientation for s in states], driven.yaw)
    saved = json.loads((run_dir / "run.json").read_text())["evaluation"]["agents"][0]
    assert saved["solution_valid"] is True and saved["score"] == pytest.approx(agent.score)


def test_a_rerun_is_not_checked_again(paper_curve_run, tmp_path):
    run, run_dir = paper_curve_run
    again = execute(RunRequest(Path(run.settings.scenario_path), validate=True), tmp_path / "again")
    assert again.fingerprint == run.fingerprint
    assert again.evaluation.solution_check == "cached" and again.evaluation.agents[0].solution_valid is True


# ------------------------------------------------------------------------------ a recorded human
def human_lane_change(oid: int = 70, x0: float = 20.0, steps: int = 120) -> DynamicObstacle:
    """A recorded car changing from lane 0 to lane 1 (a smooth step of 3.5 m over 4 s), its speed
    swinging about 12 m/s."""
    t = DT * np.arange(steps + 1)
    v = 12.0 + 1.5 * np.sin(0.5 * t)
    x = x0 + 12.0 * t + 3.0 * (1 - np.cos(0.5 * t))
    y = lane_y(0) + 3.5 * np.clip((t - 2.0) / 4.0, 0, 1) ** 2 * (3 - 2 * np.clip((t - 2.0) / 4.0, 0, 1))
    yaw = np.arctan2(np.gradient(y, DT), np.gradient(x, DT))
    curvature = np.gradient(yaw, DT) / v
    steer = np.arctan(SEDAN.wheelbase * curvature)
    states = [KSState(time_step=k, position=np.array([x[k], y[k]]), orientation=float(yaw[k]), velocity=float(v[k]),
                      steering_angle=float(steer[k])) for k in range(1, steps + 1)]
    init = InitialState(position=np.array([x[0], y[0]]), orientation=float(yaw[0]), velocity=float(v[0]),
                        time_step=0)
    shape = Rectangle(SEDAN.length, SEDAN.width)
    return DynamicObstacle(oid, ObstacleType.CAR, shape, init, TrajectoryPrediction(CrTrajectory(1, states), shape))


def recorded_scenario_with_a_human(tmp_path):
    """A recorded-like highway with traffic; the human's recorded car becomes planning problem 1
    (its obstacle removed), its recorded states the run's driven trajectory."""
    scenario = highway(lanes=2)
    human = human_lane_change()
    for obstacle in (recorded_car(50, 80.0, 0, 11.0, 150), recorded_car(51, 0.0, 1, 13.0, 150)):
        scenario.add_objects(obstacle)
    states = [human.initial_state] + human.prediction.trajectory.state_list
    end = states[-1]
    problems = PlanningProblemSet([PlanningProblem(
        1, start(float(states[0].position[0]), 0, float(states[0].velocity)),
        box_goal(float(end.position[0]), 1, (len(states) - 10, len(states) + 10)))])
    xml = tmp_path / "highway.xml"
    write_xml(scenario, problems, xml)
    driven = Trajectory(DT, t=[s.time_step * DT for s in states], x=[s.position[0] for s in states],
                        y=[s.position[1] for s in states], yaw=[s.orientation for s in states],
                        v=[s.velocity for s in states], a=np.zeros(len(states)), yaw_rate=np.zeros(len(states)),
                        steer=[getattr(s, "steering_angle", 0.0) for s in states])
    run = History(str(scenario.scenario_id), "recorded", DT, Realism.IDEAL,
                  (AgentHistory(1, SEDAN, Outcome.GOAL_REACHED, driven),))
    return scenario, problems, xml, run


@pytest.mark.parametrize("cost_function", [CostFunctionId.SM1, CostFunctionId.SM3, CostFunctionId.MW1])
def test_the_cost_of_a_recorded_human_is_the_evaluators_own(tmp_path, cost_function):
    scenario, problems, xml, run = recorded_scenario_with_a_human(tmp_path)
    solution = run_solution(run, scenario, VehicleType.BMW_320i, cost_function)
    ours = solution_costs(solution, scenario, problems)[1]
    path = tmp_path / "solution.xml"
    path.write_text(solution_xml(solution))
    read = CommonRoadSolutionReader.open(str(path))
    theirs = CostFunctionEvaluator.init_from_solution(read).evaluate_solution(scenario, problems, read).pp_results[1]
    assert ours.benchmark_id == read.benchmark_id == f"KS2:{cost_function.value}:{scenario.scenario_id}:2020a"
    assert ours.total == pytest.approx(theirs.total_costs, rel=1e-9)
    assert set(ours.partial) == {p.value for p in theirs.partial_costs}
    for p, cost in theirs.partial_costs.items():
        assert ours.partial[p.value].cost == pytest.approx(cost, rel=1e-9)
        assert ours.partial[p.value].weight == theirs.weights[p]
    assert ours.total > 0 and all(c.cost > 0 for name, c in ours.partial.items() if name in ("A", "SA", "L"))


def test_a_cost_the_library_cannot_evaluate_says_why(tmp_path):
    # the distance-to-obstacles term of WX1 uses np.math, which numpy 2 no longer has
    scenario, problems, xml, run = recorded_scenario_with_a_human(tmp_path)
    cost = solution_costs(run_solution(run, scenario, VehicleType.BMW_320i, CostFunctionId.WX1), scenario,
                          problems)[1]
    assert cost.total is None and "distance to obstacles" in cost.error and "math" in cost.error


def test_the_human_drove_a_valid_solution_and_the_verdict_is_cached(tmp_path):
    scenario, problems, xml, run = recorded_scenario_with_a_human(tmp_path)
    solution = run_solution(run, scenario, VehicleType.BMW_320i, CostFunctionId.SM1)
    cache = SolutionCheckCache(tmp_path / "cache")
    checks, cached = checked_solution(solution, scenario, problems, xml, cache)
    assert checks[1].valid is True and not cached
    again, cached = checked_solution(solution, scenario, problems, xml, cache)
    assert again == checks and cached


# ------------------------------------------------------------------------------ invalid solutions
def straight_run(scenario, speed=10.0, steps=30, jump_at=None) -> History:
    t = DT * np.arange(steps + 1)
    x = 10.0 + speed * t + (np.where(np.arange(steps + 1) >= jump_at, 3.0, 0.0) if jump_at else 0.0)
    n = len(t)
    driven = Trajectory(DT, t=t, x=x, y=np.full(n, lane_y(0)), yaw=np.zeros(n), v=np.full(n, speed),
                        a=np.zeros(n), yaw_rate=np.zeros(n), steer=np.zeros(n))
    return History(str(scenario.scenario_id), "test", DT, Realism.IDEAL,
                   (AgentHistory(1, SEDAN, Outcome.GOAL_REACHED, driven),))


def straight_problem(speed=10.0, goal_x=40.0) -> PlanningProblemSet:
    return PlanningProblemSet([PlanningProblem(1, start(10.0, 0, speed), box_goal(goal_x, 0, (0, 100)))])


def verdict(scenario, problems, run):
    return check_solution(run_solution(run, scenario, VehicleType.BMW_320i, CostFunctionId.SM1), scenario,
                          problems)[1]


def test_an_infeasible_jump_is_invalid_at_its_time():
    scenario = highway(lanes=1)
    check = verdict(scenario, straight_problem(), straight_run(scenario, jump_at=10))
    assert check.valid is False
    assert check.reason.startswith("infeasible for KS2 at t = 1.0 s"), check.reason


def test_a_collision_names_the_obstacle_and_the_time():
    scenario = highway(lanes=1)
    scenario.add_objects(recorded_car(50, 30.0, 0, 0.0, 100))     # standing, its rear at x = 27.75
    check = verdict(scenario, straight_problem(), straight_run(scenario))
    assert check.valid is False
    # the ego (type 2: 4.508 m long) reaches it with its front at 10 + 16 + 2.254 m: at t = 1.6 s
    assert check.reason == "collision with obstacle 50 at t = 1.6 s", check.reason


def test_a_missed_goal_is_the_first_reason():
    scenario = highway(lanes=1)
    check = verdict(scenario, straight_problem(goal_x=450.0), straight_run(scenario))
    assert check == type(check)(False, "goal not reached (the trajectory ends at t = 3.0 s)")


def test_the_cost_function_comes_from_the_benchmark_id_when_it_names_one(tmp_path):
    xml = tmp_path / "s.xml"
    xml.write_text('<?xml version="1.0"?>\n<commonRoad benchmarkID="KS2:WX1:DEU_A9-1_1_T-1:2020a" '
                   'commonRoadVersion="2020a" timeStepSize="0.1"></commonRoad>')
    assert cost_function_of(xml, CostFunctionId.SM1) == CostFunctionId.WX1
    xml.write_text('<commonRoad benchmarkID="DEU_A9-1_1_T-1" commonRoadVersion="2020a"></commonRoad>')
    assert cost_function_of(xml, CostFunctionId.SM1) == CostFunctionId.SM1
    assert cost_function_of(None, CostFunctionId.TR1) == CostFunctionId.TR1


def test_a_crash_of_the_checker_costs_the_verdict_not_the_run(tmp_path):
    # the `triangle` library segfaults triangulating this curve's road boundary (commonroad-
    # drivability-checker 2025.3.1); the check runs in a process of its own. The run itself keeps
    # well inside the road (its check needs no boundary): a copy of it shifted to the road's edge does.
    xml = write_scenario(build_scenario("curve", {"radius": 10.0, "angle": 60.0}), tmp_path, preview=False)
    run = execute(RunRequest(xml, validate=True), tmp_path / "run")
    assert run.evaluation.agents[0].solution_valid is True
    scenario, problems = load_scenario(xml)
    solution = run_solution(run.history, scenario, VehicleType.BMW_320i, CostFunctionId.SM1)
    for state in solution.planning_problem_solutions[0].trajectory.state_list[5:40]:
        state.position = state.position + np.array([0.0, -1.5])      # on the straight, over the right edge
    checks, _ = checked_solution(solution, scenario, problems, xml, None)
    assert checks[1] == SolutionCheck(None, "the drivability checker crashed (signal 11) in agent 1's road boundary check")
    again = execute(RunRequest(paper_curve_xml(tmp_path), validate=True), tmp_path / "after")     # the next check has a new process
    assert again.agents[0].evaluation.solution_valid is True


def test_a_footprint_at_the_road_edge_is_left_to_the_library_and_overlapping_lanelets_too():
    from simgap.evaluate import solution_check

    scenario = highway(lanes=1)
    problems = straight_problem()
    inside = run_solution(straight_run(scenario), scenario, VehicleType.BMW_320i, CostFunctionId.SM1)
    pps = inside.planning_problem_solutions[0]
    assert solution_check._well_inside_the_road(scenario, problems, pps)
    straight = straight_run(scenario)
    d = straight.driven[1]
    edge = np.where((np.arange(len(d.t)) >= 5) & (np.arange(len(d.t)) < 20), 1.5, 0.0)   # half the car beyond the edge
    over = Trajectory(DT, t=d.t, x=d.x, y=d.y + edge, yaw=d.yaw, v=d.v, a=d.a, yaw_rate=d.yaw_rate, steer=d.steer)
    off = replace(straight, agents=(replace(straight.agents[0], driven=over),))
    check = verdict(scenario, problems, off)
    assert check.valid is False and check.reason.startswith("leaves the road boundary"), check.reason
    junction = build_scenario("intersection", {}).scenario               # its lanelets overlap where they cross
    assert solution_check._road_interior(junction) is None


def test_the_checker_process_holds_none_of_its_parents_files_and_ends_with_its_pipe(paper_curve_run, tmp_path):
    # the check's process is a fork of simgap's: a file simgap has open (its stdout, a planner's pipe,
    # the pipe a caller reads simgap's output from) must not be kept open by it, nor outlive simgap
    from simgap.evaluate.validity import CheckerProcess

    run, run_dir = paper_curve_run
    scenario, problems = load_scenario(run.settings.scenario_path)
    solution = CommonRoadSolutionReader.open(str(run_dir / "solution.xml"))
    reads, writes = os.pipe()             # one end the parent keeps open while the check runs
    checker = CheckerProcess()
    try:
        checks = checker.check(run.settings.scenario_path, solution_xml(solution), [1])
        assert checks == {1: SolutionCheck(True)}
        fds = {int(fd): os.readlink(f"/proc/{checker._pid}/fd/{fd}") for fd in os.listdir(f"/proc/{checker._pid}/fd")}
        assert [fds[fd] for fd in (0, 1, 2)] == [os.devnull] * 3
        assert len(fds) == 5 and all(target.startswith("pipe:") for fd, target in fds.items() if fd > 2)
        assert os.readlink(f"/proc/self/fd/{writes}") not in fds.values()
        pid = checker._pid
        checker._send.close()             # as when simgap ends, however it ends
        assert os.waitpid(pid, 0)[1] == 0
    finally:
        os.close(reads)
        os.close(writes)


def test_a_cost_that_overflows_is_none_with_its_reason_not_inf(paper_curve_run):
    # a planner's 1e300 m/s: the acceleration term overflowed to inf, which run.json then held and
    # every reader refused as a damaged record; numpy's overflow warning reached the user
    import warnings

    run, run_dir = paper_curve_run
    scenario, problems = load_scenario(run.settings.scenario_path)
    solution = CommonRoadSolutionReader.open(str(run_dir / "solution.xml"))
    for state in solution.planning_problem_solutions[0].trajectory.state_list[10:]:
        state.velocity = 1e300
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)          # numpy's overflow
        cost = solution_costs(solution, scenario, problems)[1]
    assert cost.total is None and cost.partial == {}
    assert cost.error.startswith("the cost is not finite: its term") and "overflowed" in cost.error
