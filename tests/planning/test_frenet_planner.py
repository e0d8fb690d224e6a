"""The Frenet sampling planner: plans from any state, converges to the lane, reaches goals on
straight and sharp roads, never returns a plan through other traffic or off the road."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from commonroad.common.util import AngleInterval, Interval
from commonroad.geometry.shape import Rectangle
from commonroad.planning.goal import GoalRegion
from commonroad.scenario.state import CustomState
from planner_roads import DT, drive, lateral_offset, two_lane_road

from simgap.planning.frenet import FrenetPlanner
from simgap.planning.protocol import PlannerSetup, TrafficParticipant, World
from simgap.planning.settings import FrenetSettings
from simgap.scenario.road_frame import DrivableArea, footprint
from simgap.trajectory import State, Trajectory


def _world(road, traffic=()):
    return World(road.lanelet_network, road.problem.goal, DT, tuple(traffic))


def _lane_state(road, s, v, d=0.0, yaw_error=0.0, t=0.0, **kw):
    x, y, heading = road.ego_lane_pose(s, d)
    return State(t, x, y, heading + yaw_error, v, **kw)


def _rear_offset(planner, state):
    r = planner.vehicle.rear_axle_to_center
    return lateral_offset(planner.reference_path.xy, state.x - r * math.cos(state.yaw),
                          state.y - r * math.sin(state.yaw))


# -- one cycle ---------------------------------------------------------------------------------
def test_plan_starts_at_the_observed_state_on_the_grid(straight_planner, straight_road, sedan):
    observed = _lane_state(straight_road, 30.0, 8.0, d=0.4, yaw_error=0.05, t=1.234, a=0.5, steer=0.01)
    plan = straight_planner.plan(observed, observed.t, _world(straight_road))
    assert isinstance(plan, Trajectory) and plan.dt == DT
    assert len(plan) == 31                                   # 3.0 s horizon
    assert np.allclose(plan.t, 1.234 + DT * np.arange(31))   # starts at t, even off the grid
    first = plan[0]
    assert (first.x, first.y, first.yaw, first.v) == (observed.x, observed.y, observed.yaw, observed.v)
    # the planned step continues the observed motion (no jump)
    assert math.hypot(plan.x[1] - plan.x[0], plan.y[1] - plan.y[0]) == pytest.approx(0.8, abs=0.1)
    assert np.all(plan.v >= 0)
    # steering is the road-wheel angle of the path curvature, yaw rate = v * curvature
    kappa = np.tan(plan.steer) / sedan.wheelbase
    assert np.allclose(plan.yaw_rate, plan.v * kappa, atol=1e-9)


def test_heading_and_steering_match_the_motion_on_a_sharp_curve(curve_planner, curve_road, sedan):
    observed = _lane_state(curve_road, 100.0, 6.0, d=-0.3, yaw_error=0.05)
    plan = curve_planner.plan(observed, 0.0, _world(curve_road))
    r = sedan.rear_axle_to_center
    rx, ry = plan.x - r * np.cos(plan.yaw), plan.y - r * np.sin(plan.yaw)
    # the rear axle moves along the heading (kinematic bicycle)
    motion = np.arctan2(ry[2:] - ry[:-2], rx[2:] - rx[:-2])
    assert np.abs(np.angle(np.exp(1j * (motion - plan.yaw[1:-1])))).max() < 0.01
    # and turns by the steering's curvature
    ds = np.hypot(np.diff(rx), np.diff(ry))
    turn = np.diff(np.unwrap(plan.yaw))
    kappa = 0.5 * (np.tan(plan.steer[1:]) + np.tan(plan.steer[:-1])) / sedan.wheelbase
    assert np.abs(turn - kappa * ds).max() < 0.01


def test_planning_is_deterministic_and_stateless(sedan, curve_road, curve_planner):
    observed = _lane_state(curve_road, 60.0, 9.0, d=0.5)
    again = FrenetPlanner(PlannerSetup.for_problem(curve_road.problem, sedan, curve_road.lanelet_network),
                          FrenetSettings(concurrent_evaluation=True))
    first = curve_planner.plan(observed, 0.0, _world(curve_road))
    curve_planner.plan(_lane_state(curve_road, 10.0, 0.0), 0.0, _world(curve_road))
    assert curve_planner.plan(observed, 0.0, _world(curve_road)) == first
    assert again.plan(observed, 0.0, _world(curve_road)) == first


def test_unfollowable_observed_acceleration_is_relaxed(straight_planner, straight_road):
    """Physics may report a state no polynomial continues - here braking hard at walking speed,
    which every sample would carry into reversing: the planner then plans from pose and speed."""
    observed = _lane_state(straight_road, 40.0, 0.5, a=-8.0)
    plan = straight_planner.plan(observed, 0.0, _world(straight_road))
    assert plan is not None and straight_planner.last_cycle.relaxed
    assert (plan[0].x, plan[0].y, plan[0].yaw, plan[0].v) == (observed.x, observed.y, observed.yaw, observed.v)
    settings = FrenetSettings(relax_initial_state=False)
    strict = FrenetPlanner(PlannerSetup.for_problem(straight_road.problem, straight_planner.vehicle, straight_road.lanelet_network), settings)
    assert strict.plan(observed, 0.0, _world(straight_road)) is None
    assert strict.last_cycle.outcome == "no_feasible_sample"


def test_heading_against_the_road_gives_none(straight_planner, straight_road):
    backwards = _lane_state(straight_road, 50.0, 5.0, yaw_error=math.pi)
    assert straight_planner.plan(backwards, 0.0, _world(straight_road)) is None
    assert straight_planner.last_cycle.outcome == "projection_failed"


# -- closed loop in the ideal world ------------------------------------------------------------
def test_converges_to_the_lane_centre_from_an_offset_moving_start(straight_planner, straight_road):
    start = _lane_state(straight_road, 10.0, 10.0, d=1.0, yaw_error=0.1)
    run = drive(straight_planner, straight_road, start, steps=80, stop_at_goal=False)
    assert run.failures == 0
    offsets = [abs(_rear_offset(straight_planner, s)) for s in run.states]
    assert offsets[0] > 0.8                 # rear axle: 1 m - 1.42 m * sin(0.1)
    assert max(offsets[60:]) < 0.1          # 6 s after the start: back on the centre
    assert abs(lateral_offset(straight_planner.reference_path.xy, run.states[-1].x, run.states[-1].y)) < 0.1


@pytest.mark.parametrize("radius, angle, v0", [
    (10.0, 0.0, 0.0), (10.0, 0.0, 10.0),              # straight
    (10.0, 90.0, 0.0), (10.0, 90.0, 10.0),            # the sharp curve, left
    (10.0, -90.0, 10.0),                              # ... right (the inner lane)
    (50.0, 90.0, 0.0),
])
def test_reaches_the_goal(sedan, radius, angle, v0):
    road = two_lane_road(radius, angle, straight=50.0, v0=v0)   # shorter straights: a faster test
    planner = FrenetPlanner(PlannerSetup.for_problem(road.problem, sedan, road.lanelet_network))
    run = drive(planner, road, steps=300)
    assert run.failures == 0
    assert run.goal_time is not None and run.goal_time < 25.0
    bound = planner.settings.speed.max_lateral_acceleration
    assert max(abs(s.v * s.yaw_rate) for s in run.states) <= bound + 1e-6
    # the rear axle stays on the reference path; the whole footprint on the road
    assert max(abs(_rear_offset(planner, s)) for s in run.states[30:]) < 0.15
    road_area = DrivableArea(road.lanelet_network, tolerance=0.0)
    assert all(road_area.contains(footprint(s, sedan.length, sedan.width)) for s in run.states[::3])


# -- traffic -----------------------------------------------------------------------------------
def _parked(road, pid, s, d=0.0, length=4.5, width=1.8):
    x, y, heading = road.ego_lane_pose(s, d)
    return TrafficParticipant(pid, length, width, Trajectory.from_states([State(0.0, x, y, heading, 0.0)], DT))


def _oncoming(road, pid, s0, v, duration=20.0):
    states = []
    for k in range(int(duration / DT) + 1):
        x, y, heading = road.ego_lane_pose(s0 - v * k * DT, d=road.lane_width)
        states.append(State(k * DT, x, y, heading + math.pi, v))
    return TrafficParticipant(pid, 4.5, 1.8, Trajectory.from_states(states, DT))


def _plan_collides(plan, participant, sedan):
    for k in range(1, len(plan)):
        st = plan[k]
        other = participant.prediction.at(st.t)
        if footprint(st, sedan.length, sedan.width).intersects(
                footprint(other, participant.length, participant.width)):
            return True
    return False


def test_stops_behind_a_parked_car_when_told_to_wait(sedan, straight_road):
    """With the paper's weights and no search for a faster plan, leaving the lane costs more than
    waiting: it stops behind."""
    planner = FrenetPlanner(PlannerSetup.for_problem(straight_road.problem, sedan, straight_road.lanelet_network),
                            FrenetSettings.from_mapping({"speed": {"blocked_speed_share": 0.0}}))
    parked = _parked(straight_road, 7, 60.0)
    run = drive(planner, straight_road, _lane_state(straight_road, 10.0, 10.0), steps=100,
                world=_world(straight_road, [parked]), stop_at_goal=False)
    assert run.failures == 0
    for plan in run.plans:
        assert not _plan_collides(plan, parked, sedan)
    last = run.states[-1]
    assert last.v < 0.5
    gap = footprint(last, sedan.length, sedan.width).distance(footprint(parked.prediction[0], 4.5, 1.8))
    assert 0.1 <= gap < 3.0


def test_passes_a_parked_car_that_blocks_its_lane(sedan, straight_road, straight_planner):
    """By default a lane blocked by a standing car is left for a faster plan around it."""
    parked = _parked(straight_road, 7, 60.0)
    run = drive(straight_planner, straight_road, _lane_state(straight_road, 10.0, 10.0), steps=100,
                world=_world(straight_road, [parked]), stop_at_goal=False)
    assert run.failures == 0
    for plan in run.plans:
        assert not _plan_collides(plan, parked, sedan)
    assert run.states[-1].x > 70.0


def test_overtakes_a_parked_car_when_leaving_the_lane_is_cheap(sedan, straight_road):
    planner = FrenetPlanner(PlannerSetup.for_problem(straight_road.problem, sedan, straight_road.lanelet_network),
                            FrenetSettings.from_mapping({"costs": {"distance_to_reference_path": 1.0}}))
    parked = _parked(straight_road, 7, 60.0)
    run = drive(planner, straight_road, _lane_state(straight_road, 10.0, 10.0), steps=80,
                world=_world(straight_road, [parked]), stop_at_goal=False)
    assert run.failures == 0
    for plan in run.plans:
        assert not _plan_collides(plan, parked, sedan)
    assert run.states[-1].x > 70.0
    assert max(_rear_offset(planner, s) for s in run.states) > 1.5


def test_blocked_road_gives_none_or_a_stop_never_a_collision(sedan, straight_road, straight_planner):
    wall = _parked(straight_road, 8, 60.0, d=straight_road.lane_width / 2, length=2.0, width=7.0)
    world = _world(straight_road, [wall])
    state = _lane_state(straight_road, 10.0, 10.0)
    for _ in range(150):
        plan = straight_planner.plan(state, state.t, world)
        if plan is None:
            break
        assert not _plan_collides(plan, wall, sedan)
        state = plan.at(state.t + DT).replace(t=state.t + DT)
    else:
        assert state.v < 0.1                  # it stopped in front of the wall
    assert footprint(state, sedan.length, sedan.width).distance(
        footprint(wall.prediction[0], wall.length, wall.width)) > 0.0


def test_too_close_to_stop_gives_none(straight_road, straight_planner):
    wall = _parked(straight_road, 8, 16.0, d=straight_road.lane_width / 2, length=2.0, width=7.0)
    state = _lane_state(straight_road, 10.0, 10.0)
    assert straight_planner.plan(state, 0.0, _world(straight_road, [wall])) is None
    assert straight_planner.last_cycle.outcome == "all_colliding"


def test_never_plans_into_parked_or_oncoming_traffic(sedan, straight_road, straight_planner):
    parked = _parked(straight_road, 7, 70.0)
    oncoming = _oncoming(straight_road, 9, 140.0, 8.0)
    world = _world(straight_road, [parked, oncoming])
    run = drive(straight_planner, straight_road, _lane_state(straight_road, 10.0, 10.0), steps=120,
                world=world, stop_at_goal=False)
    for plan in run.plans:
        if plan is not None:
            assert not _plan_collides(plan, parked, sedan)
            assert not _plan_collides(plan, oncoming, sedan)
    for st in run.states:
        ego = footprint(st, sedan.length, sedan.width)
        for p in (parked, oncoming):
            assert not ego.intersects(footprint(p.prediction.at(st.t), p.length, p.width))


def test_swerving_plans_stay_on_the_road(sedan, curve_road):
    """A car parked in the curve, leaving the lane made cheap: plans swerve, but only where the
    road is (the outer edge lies 1.5 m right of the lane centre, the other lane is free)."""
    planner = FrenetPlanner(PlannerSetup.for_problem(curve_road.problem, sedan, curve_road.lanelet_network),
                            FrenetSettings.from_mapping({"costs": {"distance_to_reference_path": 0.5}}))
    parked = _parked(curve_road, 7, 112.0)
    road_area = DrivableArea(curve_road.lanelet_network, tolerance=0.0)
    run = drive(planner, curve_road, _lane_state(curve_road, 80.0, 6.0), steps=70,
                world=_world(curve_road, [parked]), stop_at_goal=False)
    assert run.failures == 0
    for plan in run.plans:
        assert not _plan_collides(plan, parked, sedan)
        assert all(road_area.contains(footprint(plan[k], sedan.length, sedan.width)) for k in range(1, len(plan), 2))
    assert run.states[-1].y > 14.0                                  # past the parked car


# -- a physical car: tracking errors of centimetres --------------------------------------------
def test_next_plan_continues_the_last_one_from_a_small_tracking_error(straight_planner, straight_road):
    """A vehicle a few centimetres off its plan is planned for from the plan (the controller
    corrects the error); one far off it is planned for from where it is."""
    start = _lane_state(straight_road, 30.0, 8.0, t=2.0)
    first = straight_planner.plan(start, start.t, _world(straight_road))
    on_plan = first[1]
    near = on_plan.replace(y=on_plan.y + 0.05, yaw=on_plan.yaw + 0.02)
    second = straight_planner.plan(near, on_plan.t, _world(straight_road))
    assert (second[0].x, second[0].y, second[0].yaw, second[0].v) == pytest.approx(
        (on_plan.x, on_plan.y, on_plan.yaw, on_plan.v))
    far = second[1].replace(y=second[1].y + 0.8)
    third = straight_planner.plan(far, far.t, _world(straight_road))
    assert (third[0].x, third[0].y) == (far.x, far.y)
    never = FrenetPlanner(PlannerSetup.for_problem(straight_road.problem, straight_planner.vehicle,
                                                   straight_road.lanelet_network),
                          FrenetSettings(continue_plan_within_m=None))
    never.plan(start, start.t, _world(straight_road))
    assert never.plan(near, on_plan.t, _world(straight_road))[0].y == near.y


def test_a_vehicle_close_to_the_road_edge_is_not_planned_off_the_road(sedan, curve_road, curve_planner):
    """On the road but within centimetres of its outer edge (as a physical car gets by tracking
    errors), before and in the sharp curve, heading along or out: no plan leaves the road (it
    used to be taken for a vehicle off the road already, whose plans may leave it for a second)."""
    road_area = DrivableArea(curve_road.lanelet_network, tolerance=0.0)
    tried = 0
    for s, v, gap, yaw_error in itertools.product(np.arange(90.0, 125.0, 2.5), (3.0, 6.0), (0.02, 0.06, 0.1),
                                                  (-0.06, -0.03, 0.0)):
        observed = _lane_state(curve_road, s, v, d=-(curve_road.lane_width / 2 - sedan.width / 2 - gap),
                               yaw_error=yaw_error)
        if not road_area.contains(footprint(observed, sedan.length, sedan.width)):
            continue
        tried += 1
        plan = curve_planner.plan(observed, 0.0, _world(curve_road))
        assert plan is None or all(road_area.contains(footprint(plan[k], sedan.length, sedan.width))
                                   for k in range(1, len(plan))), (s, v, gap, yaw_error)
    assert tried > 40


def test_a_vehicle_late_for_its_goal_window_takes_the_curve_harder(sedan):
    # 180 degrees at r = 30 m from 12.5 m/s, a goal 150 m on that must be entered by 14 s: within
    # the comfortable 4 m/s^2 the car is inside at 14.2 s (too late); recorded drivers late for
    # their window turn harder (`late_lateral_acceleration`, 6 m/s^2)
    road = two_lane_road(radius=30.0, angle_deg=180.0, straight=40.0, v0=12.5)
    area = road.problem.goal.state_list[0].position
    road.problem.goal = GoalRegion([CustomState(position=area, time_step=Interval(0, 140))])
    planner = FrenetPlanner(PlannerSetup.for_problem(road.problem, sedan, road.lanelet_network))
    run = drive(planner, road, steps=160)
    assert run.goal_time is not None and run.goal_time <= 14.0
    lateral = max(s.v ** 2 * abs(math.tan(s.steer)) / sedan.wheelbase for s in run.states)
    assert 4.0 < lateral <= planner.settings.speed.late_lateral_acceleration


@pytest.mark.parametrize("radius, offset, ahead", [(15.0, 1.0, 12.0), (25.0, -1.0, 20.0)])
def test_a_plan_that_reaches_the_goal_is_preferred_to_a_cheaper_one_that_passes_it(sedan, radius, offset, ahead):
    # a recorded goal: a 3 x 2 m box on the lane in a curve, heading the lane's way +-0.05 rad, a
    # dozen metres ahead of a car at 10 m/s a metre off the lane centre (as the recorded driver was);
    # the cheapest plans converge onto the lane with a heading lag and pass the box outside its
    # orientation window (the goal is missed on a planner that takes the cheapest plan regardless)
    road = two_lane_road(radius=radius, angle_deg=90.0, straight=60.0, start_s=50.0, v0=10.0, initial_offset=offset)
    gx, gy, heading = road.ego_lane_pose(50.0 + ahead)
    window = (heading - 0.05, heading + 0.05)
    road.problem.goal = GoalRegion([CustomState(position=Rectangle(3.0, 2.0, np.array([gx, gy]), heading),
                                                orientation=AngleInterval(*window), time_step=Interval(0, 100))])
    planner = FrenetPlanner(PlannerSetup.for_problem(road.problem, sedan, road.lanelet_network))
    run = drive(planner, road, steps=100)
    assert run.goal_time is not None and run.goal_time < 3.0
    at_goal = run.states[-1]
    assert window[0] <= at_goal.yaw <= window[1]
    assert max(s.v ** 2 * abs(math.tan(s.steer)) / sedan.wheelbase for s in run.states) \
        <= planner.settings.speed.max_lateral_acceleration + 1e-6
