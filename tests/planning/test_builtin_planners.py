"""The built-in planners `reactive` (CommonRoad's reactive planner) and `idm` (a lane-following
IDM): they reach the goal of the paper's curve road in the ideal world and in MuJoCo, plan from
any observed state, and the IDM keeps its gap behind slower traffic."""

from __future__ import annotations

import math

import numpy as np
import pytest
import shapely
from evaluated import recorded
from planner_roads import DT, drive, lateral_offset, two_lane_road

from simgap.cosim import CosimSettings, simulate
from simgap.cosim.agents import agents_from_problems
from simgap.planning.idm_planner import IdmPlanner, IdmSettings
from simgap.planning.protocol import PlannerSetup, TrafficParticipant, World
from simgap.planning.reactive import ReactivePlanner
from simgap.scenario.templates import curve
from simgap.sim.registry import make_backend
from simgap.trajectory import State, Trajectory

PLANNERS = {"reactive": ReactivePlanner, "idm": IdmPlanner}
# the reactive planner costs ~0.1 s per call in pure Python: it replans every 3 steps here (the
# upstream default), the IDM every step
REPLAN_EVERY = {"reactive": 3, "idm": 1}


def _setup(road, sedan) -> PlannerSetup:
    return PlannerSetup(1, sedan, road.lanelet_network, road.problem, DT)


def _world(road, traffic=()) -> World:
    return World(road.lanelet_network, road.problem.goal, DT, tuple(traffic))


@pytest.mark.parametrize("backend", ["ideal", "mujoco"])
@pytest.mark.parametrize("radius", [10.0, 50.0])
@pytest.mark.parametrize("name", ["reactive", "idm"])
def test_reaches_the_goal_of_the_paper_curve(name, radius, backend, sedan):
    """The paper's 90-degree curve (straights shortened to 40 m to keep the test fast)."""
    built = curve("curve", "curve", {"radius": radius, "angle": 90.0, "straight_length": 40.0})
    scenario, problems = built.scenario, built.problems
    agents = agents_from_problems(problems, scenario.dt, sedan)
    planners = {a.id: PLANNERS[name](PlannerSetup(a.id, sedan, scenario.lanelet_network,
                                                  problems.planning_problem_dict[a.id], scenario.dt))
                for a in agents}
    run = recorded(simulate(scenario, problems, make_backend(backend), agents, planners,
                            CosimSettings(replan_every=REPLAN_EVERY[name])), scenario, problems)
    (agent,) = run.agents
    assert agent.history.outcome == "goal_reached", run.history.events
    assert agent.evaluation.max_road_excursion_m == 0.0
    assert agent.history.planner_failures <= 2          # the reactive planner may miss a cycle where MuJoCo drifts


@pytest.mark.parametrize("name", ["reactive", "idm"])
def test_plans_from_an_off_centre_mis_headed_moving_start(name, sedan):
    road = two_lane_road(radius=10.0, angle_deg=90.0)
    planner = PLANNERS[name](_setup(road, sedan))
    x, y, heading = road.ego_lane_pose(40.0, 0.8)
    observed = State(2.3, x, y, heading - 0.15, 8.0, a=0.3, yaw_rate=-0.1, steer=-0.02)
    plan = planner.plan(observed, observed.t, _world(road))
    assert isinstance(plan, Trajectory) and plan.dt == DT
    np.testing.assert_allclose(plan.t, observed.t + DT * np.arange(len(plan)), atol=1e-9)
    first = plan[0]
    assert (first.x, first.y, first.yaw, first.v) == pytest.approx((observed.x, observed.y, observed.yaw, observed.v))
    assert plan.t_end >= observed.t + 2.9
    # it heads back towards the lane centre (offset measured at the centre, the lane centre at -1.5 m)
    offsets = [lateral_offset(road.centre, s.x, s.y) + road.lane_width / 2 for s in plan]
    assert abs(offsets[-1]) < 0.5 * abs(offsets[0])
    step = np.hypot(np.diff(plan.x), np.diff(plan.y))
    assert step.max() < 1.5 * max(plan.v.max(), 1.0) * DT          # no jump onto the centre line


def test_reactive_gives_none_for_a_heading_against_the_road(sedan):
    road = two_lane_road(radius=10.0, angle_deg=0.0)
    planner = ReactivePlanner(_setup(road, sedan))
    x, y, heading = road.ego_lane_pose(40.0)
    assert planner.plan(State(0.0, x, y, heading + math.pi, 5.0), 0.0, _world(road)) is None
    assert planner.failure_reason


def _footprint(x, y, yaw, length, width):
    c, s = math.cos(yaw), math.sin(yaw)
    corners = [(dx * length / 2, dy * width / 2) for dx, dy in ((1, 1), (1, -1), (-1, -1), (-1, 1))]
    return shapely.Polygon([(x + c * u - s * v, y + s * u + c * v) for u, v in corners])


def test_reactive_never_plans_into_a_parked_car(sedan):
    """A car parked in the lane 14 m ahead, seen at t = 5 s (time step 50): without it the plan
    drives through its place; with it the plan keeps clear of it at every instant."""
    road = two_lane_road(radius=10.0, angle_deg=0.0)
    planner = ReactivePlanner(_setup(road, sedan))
    x, y, heading = road.ego_lane_pose(40.0)
    observed = State(5.0, x, y, heading, 6.0)
    px, py, _ = road.ego_lane_pose(54.0)
    parked_box = _footprint(px, py, heading, sedan.length, sedan.width)
    parked = TrafficParticipant(9, sedan.length, sedan.width, Trajectory.from_states(
        [State(5.0 + k * DT, px, py, heading, 0.0) for k in range(31)], DT))

    def overlaps(plan):
        return [k for k, s in enumerate(plan) if _footprint(s.x, s.y, s.yaw, sedan.length, sedan.width)
                .intersects(parked_box)]

    assert overlaps(planner.plan(observed, observed.t, _world(road)))
    plan = planner.plan(observed, observed.t, _world(road, [parked]))
    assert plan is None or not overlaps(plan)


def test_idm_joins_the_lane_from_an_offset_and_reaches_the_goal(sedan):
    road = two_lane_road(radius=10.0, angle_deg=90.0, v0=8.0, initial_offset=1.0, initial_yaw_error=0.3)
    loop = drive(IdmPlanner(_setup(road, sedan)), road, steps=500)
    assert loop.goal_time is not None and loop.failures == 0
    later = [abs(lateral_offset(road.centre, s.x, s.y) + road.lane_width / 2) for s in loop.states[40:]]
    assert max(later) < 0.1


def _constant_speed(x0: float, y: float, v: float, t0: float, seconds: float = 6.0) -> Trajectory:
    n = int(round(seconds / DT)) + 1
    t = t0 + DT * np.arange(n)
    return Trajectory(DT, t=t, x=x0 + v * (t - t0), y=np.full(n, y), yaw=np.zeros(n), v=np.full(n, v),
                      a=np.zeros(n), yaw_rate=np.zeros(n), steer=np.zeros(n))


def test_idm_keeps_its_gap_behind_a_slower_car(sedan):
    """A car 25 m ahead at 4 m/s on the straight: the IDM closes up from 10 m/s, settles at the
    leader's speed and never comes closer than its standstill gap."""
    road = two_lane_road(radius=10.0, angle_deg=0.0, straight=300.0)
    settings = IdmSettings(cruise_m_s=12.0)
    planner = IdmPlanner(_setup(road, sedan), settings)
    x, y, heading = road.ego_lane_pose(20.0)
    state = State(0.0, x, y, heading, 10.0)
    lead_x, lead_v = x + 25.0, 4.0
    gaps, speeds = [], []
    for _ in range(300):
        lead = TrafficParticipant(7, sedan.length, sedan.width, _constant_speed(lead_x, y, lead_v, state.t))
        plan = planner.plan(state, state.t, _world(road, [lead]))
        state = plan.at(state.t + DT).replace(t=state.t + DT)
        lead_x += lead_v * DT
        gaps.append(lead_x - state.x - sedan.length)
        speeds.append(state.v)
    assert planner.last_cycle.leader == 7
    assert min(gaps) > settings.standstill_gap_m
    assert speeds[-1] == pytest.approx(lead_v, abs=0.1)
    # the steady gap is the IDM's: s0 + v T (within a few per cent)
    assert gaps[-1] == pytest.approx(settings.standstill_gap_m + lead_v * settings.time_headway_s, rel=0.1)


def test_idm_ignores_traffic_in_the_other_lane(sedan):
    road = two_lane_road(radius=10.0, angle_deg=0.0, straight=300.0)
    planner = IdmPlanner(_setup(road, sedan))
    x, y, heading = road.ego_lane_pose(20.0)
    oncoming = TrafficParticipant(8, sedan.length, sedan.width,
                                  _constant_speed(x + 20.0, y + road.lane_width, 0.0, 0.0))
    plan = planner.plan(State(0.0, x, y, heading, 8.0), 0.0, _world(road, [oncoming]))
    assert planner.last_cycle.leader != 8
    assert plan.v[-1] > 8.0


def test_idm_stops_at_the_end_of_its_route(sedan):
    road = two_lane_road(radius=10.0, angle_deg=0.0, straight=60.0)
    loop = drive(IdmPlanner(_setup(road, sedan)), road, steps=400, stop_at_goal=False)
    last = loop.states[-1]
    assert last.v < 0.05
    end_x = road.centre[-1, 0]
    assert end_x - last.x - sedan.length / 2 == pytest.approx(IdmSettings().standstill_gap_m, abs=0.5)
