"""CommonRoad goals (windows, several goal states) and obstacles of every shape and prediction kind."""

from __future__ import annotations

import math

import numpy as np
import pytest
from commonroad.common.util import AngleInterval, Interval
from commonroad.geometry.shape import Circle, Polygon, Rectangle, ShapeGroup
from commonroad.planning.goal import GoalRegion
from commonroad.prediction.prediction import Occupancy, SetBasedPrediction, TrajectoryPrediction
from commonroad.scenario.obstacle import DynamicObstacle, ObstacleType, StaticObstacle
from commonroad.scenario.scenario import Scenario
from commonroad.scenario.state import CustomState, InitialState, KSState
from commonroad.scenario.trajectory import Trajectory as CrTrajectory

from simgap.scenario.goal import Goal
from simgap.scenario.obstacles import box_of, recorded_obstacles
from simgap.trajectory import State

DT = 0.1


def ngsim_like_goal() -> Goal:
    """Arrival between 9 and 10 s, below 3.1 m/s, in a 2.3 x 1.8 m box, heading 0 +- 0.2 rad."""
    region = GoalRegion([CustomState(time_step=Interval(90, 100), velocity=Interval(0.0, 3.1),
                                     orientation=AngleInterval(-0.2, 0.2),
                                     position=Rectangle(2.3, 1.8, np.array([50.0, 0.0])))])
    return Goal.of(region, DT)


def test_every_window_of_a_goal_state_must_hold():
    goal = ngsim_like_goal()
    inside = State(t=9.5, x=50.0, y=0.0, yaw=0.05, v=2.0)
    assert goal.is_reached(inside)
    assert not goal.is_reached(inside.replace(t=8.9))          # too early
    assert not goal.is_reached(inside.replace(v=3.5))          # too fast
    assert not goal.is_reached(inside.replace(yaw=0.5))        # wrong heading
    assert not goal.is_reached(inside.replace(x=52.0))         # outside the box
    assert goal.is_reached(inside.replace(yaw=0.05 + 2 * math.pi))   # a full turn later: same heading
    assert goal.deadline_s == pytest.approx(10.0)


def test_any_goal_state_counts_and_the_deadline_is_the_latest():
    region = GoalRegion([CustomState(time_step=Interval(0, 50), position=Circle(2.0, np.array([10.0, 0.0]))),
                         CustomState(time_step=Interval(0, 120), position=Circle(2.0, np.array([90.0, 0.0])))])
    goal = Goal.of(region, DT)
    assert goal.is_reached(State(t=11.0, x=90.0, y=0.0, yaw=0.0, v=5.0))
    assert not goal.is_reached(State(t=6.0, x=10.0, y=0.0, yaw=0.0, v=5.0))   # the first one's time is over
    assert goal.deadline_s == pytest.approx(12.0)


def test_a_miss_is_explained():
    goal = ngsim_like_goal()
    passed_fast = [State(t=k * DT, x=5.0 * k * DT, y=0.0, yaw=0.0, v=5.0) for k in range(120)]
    reason = goal.miss_reason(passed_fast)
    assert "inside the goal position" in reason and "velocity 5.00 m/s outside 0-3.1 m/s" in reason
    assert "never inside" in goal.miss_reason([State(0.0, 0.0, 10.0, 0.0, 0.0)])


def test_a_miss_is_judged_at_the_time_window_not_at_the_early_arrival():
    # in the goal box from 7.6 s on, through the time window at 10 m/s: the velocity missed, at the window
    region = GoalRegion([CustomState(time_step=Interval(146, 147), velocity=Interval(-3.24, 9.76),
                                     position=Rectangle(100.0, 4.0, np.array([126.0, 0.0])))])
    driven = [State(t=k * DT, x=10.0 * k * DT, y=0.0, yaw=0.0, v=10.0) for k in range(148)]
    reason = Goal.of(region, DT).miss_reason(driven)
    assert reason.startswith("in the time window 14.6-14.7 s at t = 14.6 s inside the goal position but")
    assert "velocity 10.00 m/s outside -3.24-9.76 m/s" in reason and "time" not in reason.split("but")[1]
    # never in the box: how far from it, at the window
    away = [st.replace(y=8.0) for st in driven]
    assert Goal.of(region, DT).miss_reason(away).startswith("never inside the goal position (6.0 m from it")


def test_a_goal_never_entered_is_missed_by_the_closest_approach():
    # stop in a box 100 m ahead within 20 s; the car starts at rest (inside the velocity window) and
    # drives towards it at 4 m/s (outside): the miss is how close it came, at the end, not at the start
    region = GoalRegion([CustomState(time_step=Interval(0, 200), velocity=Interval(0.0, 0.1),
                                     position=Rectangle(10.0, 3.5, np.array([100.0, 0.0])))])
    driven = [State(t=k * DT, x=4.0 * k * DT, y=0.0, yaw=0.0, v=0.0 if k == 0 else 4.0) for k in range(201)]
    assert Goal.of(region, DT).miss_reason(driven).startswith("never inside the goal position (15.0 m from it at t = 20.0 s")


def test_shapes_become_oriented_boxes():
    assert box_of(Rectangle(4.0, 2.0)) .length == pytest.approx(4.0)
    circle = box_of(Circle(0.5, np.array([1.0, 0.0])))
    assert (circle.length, circle.width, circle.dx) == pytest.approx((1.0, 1.0, 1.0))
    tilted = Polygon(np.array([[0, 0], [3, 3], [2.5, 3.5], [-0.5, 0.5]], dtype=float))
    box = box_of(tilted)
    assert box.length == pytest.approx(math.hypot(3, 3), abs=1e-6)
    assert box.width == pytest.approx(math.hypot(0.5, 0.5), abs=1e-6)
    assert math.cos(2 * (box.yaw - math.pi / 4)) == pytest.approx(1.0)
    group = box_of(ShapeGroup([Rectangle(1.0, 1.0, np.array([-2.0, 0.0])), Rectangle(1.0, 1.0, np.array([2.0, 0.0]))]))
    assert (group.length, group.width, group.dx) == pytest.approx((5.0, 1.0, 0.0), abs=1e-6)


def _scenario_with_every_obstacle_kind() -> Scenario:
    scenario = Scenario(DT)
    init = InitialState(position=np.array([10.0, 0.0]), orientation=0.0, velocity=5.0, time_step=0)
    states = [KSState(time_step=k, position=np.array([10.0 + 0.5 * k, 0.0]), orientation=0.0, velocity=5.0,
                      steering_angle=0.0) for k in range(1, 21)]
    shape = Circle(0.4)
    scenario.add_objects(DynamicObstacle(1, ObstacleType.PEDESTRIAN, shape, init,
                                         TrajectoryPrediction(CrTrajectory(1, states), shape)))
    occupancies = [Occupancy(k, Rectangle(4.0 + 0.1 * k, 2.0, np.array([30.0 + 1.0 * k, 3.5])))
                   for k in (1, 2, 4)]   # a gap at step 3
    scenario.add_objects(DynamicObstacle(
        2, ObstacleType.CAR, Rectangle(4.0, 2.0), InitialState(position=np.array([30.0, 3.5]), orientation=0.0,
                                                               velocity=10.0, time_step=0),
        SetBasedPrediction(1, occupancies)))
    scenario.add_objects(StaticObstacle(3, ObstacleType.PARKED_VEHICLE,
                                        Polygon(np.array([[-1, -0.5], [1, -0.5], [1, 0.5], [-1, 0.5]], float)),
                                        InitialState(position=np.array([60.0, 0.0]), orientation=math.pi / 2,
                                                     velocity=0.0, time_step=0)))
    return scenario


def test_every_obstacle_kind_is_recorded():
    by_id = {o.id: o for o in recorded_obstacles(_scenario_with_every_obstacle_kind())}
    pedestrian, set_based, parked = by_id[1], by_id[2], by_id[3]
    assert not pedestrian.vehicle and pedestrian.length == pytest.approx(0.8)
    assert pedestrian.motion.at(1.0).x == pytest.approx(15.0)
    # the set-based prediction: centres of the occupancies, the gap interpolated, the largest box
    assert set_based.motion.at(0.3).x == pytest.approx(33.0)
    assert set_based.length == pytest.approx(4.4) and set_based.width == pytest.approx(2.0)
    # a static obstacle stands for ever, rotated as its state says
    assert parked.static and parked.motion.at(500.0).x == pytest.approx(60.0)
    assert parked.length == pytest.approx(2.0) and math.sin(parked.motion.at(0.0).yaw) ** 2 == pytest.approx(1.0)


def test_many_states_at_once_are_judged_as_one_at_a_time():
    # the planner judges every state of its sampled plans at once (`Goal.reached_at`): the same
    # verdicts as `is_reached`, state by state, for a box with every window and for a goal of two
    # states (a polygon; a lanelet-like shape group), headings on the circle included
    rng = np.random.default_rng(7)
    two_states = Goal.of(GoalRegion([
        CustomState(time_step=Interval(20, 40), position=Polygon(np.array([[0.0, -2.0], [8.0, -2.0], [6.0, 3.0], [0.0, 2.0]]))),
        CustomState(time_step=Interval(0, 100), orientation=AngleInterval(3.0, 3.3),
                    position=ShapeGroup([Rectangle(4.0, 2.0, np.array([20.0, 0.0])), Circle(1.5, np.array([25.0, 0.0]))]))]), DT)
    # sampled around each goal (times, places, headings and speeds near its windows, some inside)
    for goal, t_range, x_range, turn in ((ngsim_like_goal(), (8.5, 10.5), (48.0, 52.0), 0.0),
                                         (two_states, (1.0, 5.0), (-2.0, 28.0), 3.15)):
        n = 4000
        t = rng.uniform(*t_range, n).round(1)
        x = rng.uniform(*x_range, n)
        y = rng.uniform(-2.5, 2.5, n)
        yaw = turn + rng.uniform(-0.5, 0.5, n) + 2 * math.pi * rng.integers(-1, 2, n)
        v = rng.uniform(0.0, 5.0, n)
        at_once = goal.reached_at(t, x, y, yaw, v)
        one_by_one = np.array([goal.is_reached(State(t=t[i], x=x[i], y=y[i], yaw=yaw[i], v=v[i])) for i in range(n)])
        assert 100 < at_once.sum() < n - 100
        assert np.array_equal(at_once, one_by_one)
