"""The loop on its own: a straight road, test planners that drive straight lines."""

from __future__ import annotations

import math
import pickle
import time

import numpy as np
import pyarrow.parquet as pq
import pytest
from commonroad.common.util import Interval
from commonroad.geometry.shape import Rectangle
from commonroad.planning.goal import GoalRegion
from commonroad.planning.planning_problem import PlanningProblem, PlanningProblemSet
from commonroad.scenario.lanelet import Lanelet, LaneletNetwork
from commonroad.scenario.scenario import Scenario
from commonroad.scenario.state import CustomState, InitialState
from evaluated import recorded

from simgap.cosim import CosimSettings, EventKind, Outcome, simulate
from simgap.cosim.agents import agents_from_problems
from simgap.record import RunFiles, read_run, write_run
from simgap.scenario.geometry import Straight, centre_line
from simgap.scenario.relief import ElevationProfile, ReliefProfile, RoadRelief
from simgap.scenario.road_frame import footprint
from simgap.sim.ideal import IdealBackend
from simgap.sim.registry import make_backend
from simgap.trajectory import State, Trajectory
from simgap.vehicles import load_vehicle

DT = 0.1


def straight_road(length=200.0, width=3.5):
    left = np.array([[0.0, width], [length, width]])
    center = np.array([[0.0, width / 2], [length, width / 2]])
    right = np.array([[0.0, 0.0], [length, 0.0]])
    lanelet = Lanelet(left, center, right, 1)
    scenario = Scenario(DT)
    scenario.add_objects(LaneletNetwork.create_from_lanelet_list([lanelet]))
    return scenario


def problem(pid, x, y, yaw, v, goal_x, goal_y=1.75, t_end=200):
    init = InitialState(position=np.array([x, y]), orientation=yaw, velocity=v, acceleration=0.0,
                        yaw_rate=0.0, slip_angle=0.0, time_step=0)
    goal = GoalRegion([CustomState(position=Rectangle(10.0, 3.0, np.array([goal_x, goal_y])),
                                   time_step=Interval(0, t_end))])
    return PlanningProblem(pid, init, goal)


class StraightLine:
    """Test planner: constant speed along the current heading (None if told to fail)."""

    def __init__(self, speed=10.0, fail_after=None, crash=False):
        self.speed, self.fail_after, self.calls, self.crash = speed, fail_after, 0, crash

    def plan(self, observed: State, t: float, world) -> Trajectory | None:
        self.calls += 1
        if self.fail_after is not None and self.calls > self.fail_after:
            if self.crash:
                raise RuntimeError("solver exploded")
            return None
        states = []
        for k in range(31):
            d = self.speed * k * world.dt
            states.append(State(t + k * world.dt, observed.x + d * math.cos(observed.yaw),
                                observed.y + d * math.sin(observed.yaw), observed.yaw, self.speed))
        return Trajectory.from_states(states, world.dt)


def run(problems, planners, settings=None):
    """The run simulated, evaluated and recorded (`RunRecord`)."""
    scenario = straight_road()
    pps = PlanningProblemSet(problems)
    agents = agents_from_problems(pps, DT, load_vehicle("sedan"))
    return recorded(simulate(scenario, pps, IdealBackend(), agents, planners, settings), scenario, pps, settings)


def test_single_agent_reaches_goal_at_the_expected_time():
    result = run([problem(1, 10, 1.75, 0.0, 10.0, 150)], {1: StraightLine(10.0)})
    (agent,) = result.agents
    assert agent.history.outcome == "goal_reached"
    # the goal rectangle spans x in [145, 155]: from x = 10 at 10 m/s the centre enters it at 13.5 s
    assert agent.history.time_to_goal_s == pytest.approx(13.6, abs=0.11)
    assert agent.evaluation.distance_m == pytest.approx(136.0, abs=1.1)


def test_head_on_agents_collide():
    result = run([problem(1, 10, 1.75, 0.0, 10.0, 190), problem(2, 190, 1.75, math.pi, 10.0, 10)],
                 {1: StraightLine(10.0), 2: StraightLine(10.0)})
    assert [a.history.outcome for a in result.agents] == ["collision", "collision"]
    ev = [e for e in result.history.events if e.kind == "collision"]
    assert {e.other_id for e in ev} == {1, 2}
    assert all(a.evaluation.min_distance_to_traffic_m == 0.0 for a in result.agents)


def test_planner_failure_triggers_emergency_stop():
    settings = CosimSettings(planner_failure_limit=3)
    result = run([problem(1, 10, 1.75, 0.0, 10.0, 150)], {1: StraightLine(10.0, fail_after=5)}, settings)
    (agent,) = result.agents
    assert agent.history.outcome == "planner_failure"
    assert agent.history.planner_failures == 3
    v = result.history.driven[1].v
    assert v[-1] < v[5]  # it braked
    assert any(e.kind == "planner_no_solution" for e in result.history.events)


def test_a_crashing_planner_fails_its_agent_with_the_reason(tmp_path):
    settings = CosimSettings(planner_failure_limit=2)
    result = run([problem(1, 10, 1.75, 0.0, 10.0, 150)], {1: StraightLine(10.0, fail_after=3, crash=True)}, settings)
    assert result.agents[0].history.outcome == "planner_failure"
    assert any("RuntimeError: solver exploded" in e.detail for e in result.history.events)
    assert [e.kind for e in result.history.events] == [EventKind.PLANNER_NO_SOLUTION] * 2 + [Outcome.PLANNER_FAILURE]
    write_run(RunFiles(result), tmp_path / "run")
    assert read_run(tmp_path / "run").history.events == result.history.events       # typed again when read


def test_leaving_the_road_is_off_road():
    result = run([problem(1, 10, 1.75, 0.2, 10.0, 150)], {1: StraightLine(10.0)})
    (agent,) = result.agents
    assert agent.history.outcome == "off_road"
    assert agent.evaluation.max_road_excursion_m > 0


def test_run_record_reloads_equal(tmp_path):
    result = run([problem(1, 10, 1.75, 0.0, 10.0, 150)], {1: StraightLine(10.0)},
                 CosimSettings(replan_every=3))
    write_run(RunFiles(result), tmp_path / "run")
    again = read_run(tmp_path / "run")
    assert again.fingerprint == result.fingerprint
    assert again == result            # history (states, plans, observations, call times), evaluation, settings
    assert pickle.loads(pickle.dumps(result)) == result      # a record crosses processes (executors, Ray)


def test_a_world_with_a_relief_records_each_driven_states_attitude_and_the_ideal_world_none(tmp_path):
    relief = RoadRelief(ReliefProfile(elevation=ElevationProfile(grade=5.0)),
                        centre_line([Straight(length=200.0)], start=(0.0, 1.75), max_step=0.2))
    problems = PlanningProblemSet([problem(1, 10, 1.75, 0.0, 10.0, 150)])
    agents = agents_from_problems(problems, DT, load_vehicle("sedan"))
    ideal = recorded(simulate(straight_road(), problems, IdealBackend(), agents, {1: StraightLine(10.0)},
                              relief=relief), straight_road(), problems)
    assert ideal.history.agents[0].attitudes == ()
    write_run(RunFiles(ideal), tmp_path / "ideal")
    assert "z" not in pq.read_table(tmp_path / "ideal" / "trajectories.parquet").column_names
    physical = recorded(simulate(straight_road(), problems, make_backend("dynamic"), agents, {1: StraightLine(10.0)},
                                 relief=relief), straight_road(), problems)
    attitudes, driven = physical.history.agents[0].attitudes, physical.history.driven[1]
    assert len(attitudes) == len(driven)
    assert np.array([a.pitch for a in attitudes]) == pytest.approx(math.atan(0.05), abs=1e-4)   # (its heading wavers)
    assert np.array([a.z for a in attitudes]) == pytest.approx(0.05 * driven.x + 0.61373 / math.cos(math.atan(0.05)),
                                                                abs=1e-3)
    write_run(RunFiles(physical), tmp_path / "dynamic")
    assert read_run(tmp_path / "dynamic").history.agents[0].attitudes == attitudes


def test_replan_every_n_plans_less_often():
    every1 = StraightLine(10.0)
    every3 = StraightLine(10.0)
    run([problem(1, 10, 1.75, 0.0, 10.0, 150)], {1: every1})
    run([problem(1, 10, 1.75, 0.0, 10.0, 150)], {1: every3}, CosimSettings(replan_every=3))
    assert every3.calls == pytest.approx(every1.calls / 3, abs=1)


def test_the_goals_time_window_is_the_deadline_not_a_default_cap():
    # the goal allows 100 s; at 2 m/s the goal box (x in [145, 155]) is reached after about 68 s,
    # beyond the 60 s the loop allows a goal without a time window
    result = run([problem(1, 10, 1.75, 0.0, 2.0, 150, t_end=1000)], {1: StraightLine(2.0)})
    assert result.agents[0].history.outcome == "goal_reached"
    assert result.agents[0].history.time_to_goal_s == pytest.approx(67.6, abs=0.2)


def test_a_timeout_says_why_the_goal_was_missed():
    result = run([problem(1, 10, 1.75, 0.0, 10.0, 150, t_end=50)], {1: StraightLine(10.0)})
    (event,) = [e for e in result.history.events if e.kind == "timeout"]
    assert result.agents[0].history.outcome == "timeout"
    assert "goal not reached by t = 5.0 s: never inside the goal position" in event.detail


def test_a_failing_planner_brakes_along_its_last_plan():
    from simgap.cosim.plan_delivery import emergency_stop

    arc = Trajectory.from_states([State(k * DT, 20 * math.sin(0.05 * k), 20 - 20 * math.cos(0.05 * k), 0.05 * k, 10.0)
                                  for k in range(31)], DT)
    stop = emergency_stop(arc[0], DT, 8.0, path=arc)
    assert stop.v[-1] == 0.0
    # it stops on the arc (radius 20 m around (0, 20)), not on the straight tangent
    assert math.hypot(stop.x[-1], stop.y[-1] - 20) == pytest.approx(20.0, abs=0.05)
    assert stop.y[-1] > 0.5


class Returns:
    """Test planner that returns ``make(observed, t, dt)`` (a good plan from `StraightLine` first, if asked)."""

    def __init__(self, make, good_cycles=0):
        self.make, self.good, self.calls = make, StraightLine(10.0), 0
        self.good_cycles = good_cycles

    def plan(self, observed, t, world):
        self.calls += 1
        if self.calls <= self.good_cycles:
            return self.good.plan(observed, t, world)
        return self.make(observed, t, world.dt)


def line(t0, dt, n=31, **changes):
    """A straight plan of ``n`` states at 10 m/s from x = 10 starting at ``t0`` (columns replaced by ``changes``)."""
    columns = dict(t=t0 + dt * np.arange(n), x=10 + 10 * dt * np.arange(n), y=np.full(n, 1.75), yaw=np.zeros(n),
                   v=np.full(n, 10.0), a=np.zeros(n), yaw_rate=np.zeros(n), steer=np.zeros(n))
    return Trajectory(dt, **(columns | changes))


@pytest.mark.parametrize("make, reason", [
    (lambda s, t, dt: {"x": [1, 2]}, "a dict, not a Trajectory"),
    (lambda s, t, dt: "forward", "a str, not a Trajectory"),
    (lambda s, t, dt: line(t, dt, x=np.r_[10.0, np.nan, np.zeros(29)]), "x[1] is nan"),
    (lambda s, t, dt: line(t, dt, v=np.r_[np.full(30, 10.0), np.inf]), "v[30] is inf"),
    (lambda s, t, dt: line(t, dt, n=1), "1 state; a plan needs at least 2"),
    (lambda s, t, dt: line(t + 1.0, dt), "planned at t = 0.3 s"),
    (lambda s, t, dt: line(t, 2 * dt), "dt = 0.2 s, the scenario's time step is 0.1 s"),
    (lambda s, t, dt: line(t, dt, t=t + dt * np.r_[np.arange(10), np.arange(11, 32)]), "t[10]"),
])
def test_a_plan_the_loop_cannot_execute_fails_its_cycle_with_the_reason(make, reason):
    result = run([problem(1, 10, 1.75, 0.0, 10.0, 150)], {1: Returns(make, good_cycles=3)},
                 CosimSettings(planner_failure_limit=2))
    (agent,) = result.agents
    assert agent.history.outcome == "planner_failure" and agent.history.planner_failures == 2 and agent.history.planner_exceptions == 0
    failed = [e for e in result.history.events if e.kind == "planner_no_solution"]
    assert failed[0].t == pytest.approx(0.3) and "invalid plan: " in failed[0].detail and reason in failed[0].detail
    assert len(result.history.plans[1]) == 3


def test_plans_are_cut_to_the_horizon_cap():
    from simgap.planning.plan_check import MAX_PLAN_HORIZON_S

    result = run([problem(1, 10, 1.75, 0.0, 10.0, 150, t_end=20)],
                 {1: Returns(lambda s, t, dt: line(t, dt, n=1_000_000, x=s.x + 10 * dt * np.arange(1_000_000)))})
    plans = result.history.plans[1]
    assert len(plans) == 20 and result.agents[0].history.planner_failures == 0
    assert {len(p) for p in plans} == {int(MAX_PLAN_HORIZON_S / DT) + 1}
    assert plans[5].t_end == pytest.approx(0.5 + MAX_PLAN_HORIZON_S)


class Exits:
    """Test planner that raises ``exc`` from every planning call."""

    def __init__(self, exc: BaseException):
        self.exc = exc

    def plan(self, observed, t, world):
        raise self.exc


class OwnBaseException(BaseException):
    """What a planner's author may raise: not an Exception."""


@pytest.mark.parametrize("exc, text", [(SystemExit(3), "SystemExit: 3"), (KeyboardInterrupt(), "KeyboardInterrupt"),
                                       (OwnBaseException("mine"), "OwnBaseException: mine")])
def test_a_planner_that_exits_or_interrupts_fails_its_cycles_not_the_process(exc, text):
    result = run([problem(1, 10, 1.75, 0.0, 10.0, 150)], {1: Exits(exc)}, CosimSettings(planner_failure_limit=2))
    (agent,) = result.agents
    assert agent.history.outcome == "planner_failure" and agent.history.planner_exceptions == 2
    assert f"planner raised {text}" in result.history.events[0].detail
    assert result.history.planner_errors[0].exception == type(exc).__name__


class NeverReturns:
    """Test planner whose first planning call does not return."""

    def plan(self, observed, t, world):
        while True:
            time.sleep(0.01)


def test_a_planning_call_that_never_returns_ends_the_run_at_its_wall_time_limit():
    scenario, pps = straight_road(), PlanningProblemSet([problem(1, 10, 1.75, 0.0, 10.0, 150)])
    clock = time.perf_counter()
    result = simulate(scenario, pps, IdealBackend(), agents_from_problems(pps, DT, load_vehicle("sedan")),
                      {1: NeverReturns()}, wall_time_limit_s=0.5)
    assert time.perf_counter() - clock < 5.0
    assert result.failure == "timeout: still running after 0.5 s of wall time in agent 1's planning call at t = 0.0 s"
    assert result.agents[0].outcome == "timeout" and result.events[-1].detail == result.failure


def test_an_absurd_goal_window_is_capped_at_the_longest_simulated_time():
    from simgap.cosim.loop import MAX_SIMULATED_TIME_S, deadline
    from simgap.scenario.goal import Goal

    goal = Goal.of(problem(1, 10, 1.75, 0.0, 10.0, 150, t_end=2_000_000_000).goal, DT)
    assert deadline(goal, CosimSettings()) == MAX_SIMULATED_TIME_S == 600.0
    assert deadline(Goal.of(problem(1, 10, 1.75, 0.0, 10.0, 150, t_end=50).goal, DT), CosimSettings()) == 5.0


def parked_cars(scenario, rows: int, first_row_y: float = 100.0):
    """Rows of 100 parked cars, 10 m apart, from ``first_row_y`` away from the road."""
    from commonroad.geometry.shape import Rectangle
    from commonroad.scenario.obstacle import ObstacleType, StaticObstacle

    for k in range(100 * rows):
        position = np.array([(k % 100) * 10.0, first_row_y + (k // 100) * 10.0])
        scenario.add_objects(StaticObstacle(1000 + k, ObstacleType.PARKED_VEHICLE, Rectangle(4.5, 1.8),
                                            InitialState(position=position, orientation=0.0, time_step=0)))
    return scenario


def test_far_away_obstacles_add_no_footprint_checks(monkeypatch):
    import simgap.cosim.judging as judging
    import simgap.evaluate.closest_approach as closest_approach

    built = []
    for module in (judging, closest_approach):         # the monitors, and the measure of the closest approach
        monkeypatch.setattr(module, "footprint", lambda *shape: built.append(shape) or footprint(*shape))
    pps = PlanningProblemSet([problem(1, 10, 1.75, 0.0, 10.0, 150, t_end=30)])
    gaps, footprints = [], []
    for rows in (1, 50):            # 100 and 5000 parked cars
        built.clear()
        scenario = parked_cars(straight_road(), rows)
        result = recorded(simulate(scenario, pps, IdealBackend(), agents_from_problems(pps, DT, load_vehicle("sedan")),
                                   {1: StraightLine(10.0)}), scenario, pps)
        gaps.append(result.agents[0].evaluation.min_distance_to_traffic_m)
        footprints.append(len(built))
    assert gaps[0] == gaps[1] == pytest.approx(100 - 0.9 - 1.75 - load_vehicle("sedan").width / 2, abs=1e-3)
    assert footprints[1] == footprints[0] < 30 * 10          # the other 49 rows: not one footprint
