"""The lazily evaluated cost order gives the frenetix core's own order, and the planner's plans do
not change for it: the floor is below every feasible sample's cost (and close to it), and a
closed loop with the floor switched off (every sample evaluated before the first is handed out)
drives the same states."""

from __future__ import annotations

import numpy as np
import pytest
from planner_roads import drive, start_state

import simgap.planning.frenet_evaluation as frenet_evaluation
from simgap.planning.cost_order import CostOrder, cost_floor
from simgap.planning.frenet import CycleMemory, FrenetPlanner, PlanningCycle
from simgap.planning.protocol import PlannerSetup, TrafficParticipant, World
from simgap.planning.sampling import end_speeds, end_times, lateral_offsets, sampling_matrix, steps_in_horizon
from simgap.trajectory import State, Trajectory

DT = 0.1


def _states(planner, road, steps=90):
    """Observed states along a closed loop from standstill (low-velocity mode first)."""
    return drive(planner, road, steps=steps, stop_at_goal=False).states


def _cycle_matrix(planner, state, dt=DT):
    start = planner.project(state, state.t, dt, PlanningCycle())
    s = planner.settings
    matrix = sampling_matrix(start.x0_lon, start.x0_lat, end_times(s.sampling, dt),
                             end_speeds(s.sampling, start.v, start.desired, planner.vehicle.limits.max_speed),
                             lateral_offsets(s.sampling))
    return start, matrix


def _core_order(planner, start, matrix, dt=DT):
    """The core's feasible samples, every one evaluated, sorted: (cost, row)."""
    order = planner.cost_order(start, PlanningCycle())
    rows = np.arange(len(matrix))
    return sorted((cost, row) for cost, row, _ in order._evaluate(rows))


@pytest.mark.parametrize("step", [0, 3, 12, 40, 80])
def test_the_floor_is_below_and_close_to_the_core_cost_of_every_feasible_sample(curve_planner, curve_road, step):
    state = _states(curve_planner, curve_road)[step]
    start, matrix = _cycle_matrix(curve_planner, state)
    # cost_order builds the same matrix (no manoeuvre to continue: none is passed, and the memory is reset)
    curve_planner.memory = CycleMemory()
    costs = _core_order(curve_planner, start, matrix)
    assert len(costs) > 50
    points = steps_in_horizon(curve_planner.settings.sampling, DT) + 1
    floor = cost_floor(matrix, DT, points, start.low_velocity, start.desired, curve_planner.settings.costs,
                       curve_planner._core_reference)
    gaps = np.array([(cost - floor[row]) / cost for cost, row in costs])
    assert (gaps >= 0).all(), f"floor above the core's cost by {-gaps.min():.2e} (relative)"
    assert np.median(gaps) < 1e-4


@pytest.mark.parametrize("step", [0, 12, 60])
def test_samples_come_in_the_core_order(curve_planner, curve_road, step):
    state = _states(curve_planner, curve_road)[step]
    curve_planner.memory = CycleMemory()
    start, matrix = _cycle_matrix(curve_planner, state)
    everything = [row for _, row in _core_order(curve_planner, start, matrix)]
    order = curve_planner.cost_order(start, PlanningCycle())
    handed = []
    while batch := order.take(7):
        handed += [int(start_row) for start_row in _rows_of(batch, matrix)]
    assert handed == everything
    assert order.floor_misses == 0


def _rows_of(samples, matrix):
    """Row of the sampling matrix each sample was generated from (by its sampling parameters)."""
    params = np.array([s.sampling_parameters for s in samples])
    return [int(np.flatnonzero(np.all(np.isclose(matrix, p, rtol=0, atol=1e-12), axis=1))[0]) for p in params]


def test_a_cycle_evaluates_a_small_share_of_its_samples(curve_planner, curve_road):
    state = _states(curve_planner, curve_road)[40]
    curve_planner.plan(state, state.t, World(curve_road.lanelet_network, curve_road.problem.goal, DT))
    cycle = curve_planner.last_cycle
    assert cycle.outcome == "planned"
    assert cycle.floor_misses == 0
    assert cycle.evaluated <= cycle.samples // 4


def test_take_hands_out_by_cost_whatever_the_batches():
    floor = np.array([0.0, 1.0, 2.0, 5.0, 3.0, 4.0])
    cost = floor + np.array([2.5, 0.2, 0.1, 0.0, 0.05, 0.3])     # every cost at or above its floor
    seen = []

    def evaluate(rows):
        seen.extend(rows.tolist())
        return [(float(cost[r]), int(r), int(r)) for r in rows if r != 4]    # row 4 infeasible

    order = CostOrder(floor, evaluate)
    assert order.take(10) == sorted((r for r in range(6) if r != 4), key=lambda r: cost[r])
    assert order.feasible == 5 and order.evaluated == 6 and order.floor_misses == 0
    assert sorted(seen) == list(range(6))


def test_a_floor_above_a_cost_is_counted_and_the_rest_evaluated_at_once():
    floor = np.linspace(0.0, 10.0, 40)
    cost = floor.copy()
    cost[2] = -1.0                                           # below its floor: a wrong replica
    order = CostOrder(floor, lambda rows: [(float(cost[r]), int(r), int(r)) for r in rows])
    first = order.take(1)
    assert order.floor_misses == 1
    assert order.evaluated == 40
    assert first == [2]


def _no_floor(matrix, *args, **kwargs):
    return np.zeros(len(matrix))


def _crossing(road, pid):
    """A car crossing the ego's lane ahead of it, at walking pace."""
    states = []
    for k in range(200):
        x, y, heading = road.ego_lane_pose(45.0, d=3.0 - 0.04 * k)
        states.append(State(k * DT, x, y, heading - np.pi / 2, 0.4))
    return TrafficParticipant(pid, 4.5, 1.8, Trajectory.from_states(states, DT))


@pytest.mark.parametrize("traffic", [False, True])
def test_closed_loop_plans_equal_those_of_the_whole_evaluation(sedan, straight_road, curve_road, monkeypatch,
                                                                traffic):
    road = straight_road if traffic else curve_road
    world = World(road.lanelet_network, road.problem.goal, DT, (_crossing(road, 9),) if traffic else ())

    def closed_loop():
        planner = FrenetPlanner(PlannerSetup.for_problem(road.problem, sedan, road.lanelet_network))
        run = drive(planner, road, start_state(road), steps=150, world=world)
        return run, planner

    lazy, planner = closed_loop()
    with monkeypatch.context() as m:
        m.setattr(frenet_evaluation, "cost_floor", _no_floor)
        whole, _ = closed_loop()
    assert len(lazy.plans) == len(whole.plans)
    for a, b in zip(lazy.plans, whole.plans):
        assert (a is None) == (b is None)
        if a is not None:
            np.testing.assert_array_equal(a.x, b.x)
            np.testing.assert_array_equal(a.v, b.v)
    assert lazy.goal_time == whole.goal_time
