"""The closed-loop score's parts on hand-computed cases: each comfort bound, each multiplier, the
TTC, speed-limit compliance, the weighted mean, and what a score drop is made of."""

from __future__ import annotations

import math

import numpy as np
import pytest
from commonroad.scenario.traffic_sign import TrafficSign, TrafficSignElement, TrafficSignIDZamunda
from cosim.real_like import highway, lane_y

from simgap.cosim.history import Outcome
from simgap.evaluate.at_fault import Collision, CollisionType, at_fault, collision_type
from simgap.evaluate.closed_loop_score import (
    collision_multiplier,
    combine,
    direction_multiplier,
    drivable_area_multiplier,
    progress_ratio,
    speed_limit_compliance,
    worst_wrong_way,
)
from simgap.evaluate.lane_occupancy import LaneOccupancy
from simgap.evaluate.ride_comfort import comfort_check
from simgap.evaluate.road_users import RoadUser, RoadUserKind
from simgap.evaluate.run_evaluation import AgentEvaluation
from simgap.evaluate.score_drop import score_drop
from simgap.evaluate.settings import ComfortBounds, ScoreSettings, ScoreWeights
from simgap.evaluate.time_to_collision import time_to_collision
from simgap.trajectory import State, Trajectory

DT = 0.1
SETTINGS = ScoreSettings()


def traj(t, x=None, y=None, yaw=None, v=None, a=None, yaw_rate=None) -> Trajectory:
    t = np.asarray(t, dtype=float)
    n = len(t)

    def col(values, default=0.0):
        return np.full(n, default) if values is None else np.broadcast_to(np.asarray(values, dtype=float), (n,))

    return Trajectory(DT, t=t, x=col(x), y=col(y), yaw=col(yaw), v=col(v, 10.0), a=col(a), yaw_rate=col(yaw_rate),
                      steer=np.zeros(n))


# ------------------------------------------------------------------------------ comfort bounds
# The signals are constant, linear or quadratic in time, which the Savitzky-Golay filters (order
# 2 and 3) reproduce exactly: the filtered values are the hand-computed ones.
T20 = DT * np.arange(20)
T6 = DT * np.arange(6)          # 0 .. 0.5 s
T5 = DT * np.arange(5)          # 0 .. 0.4 s

COMFORT_CASES = [
    # (bound broken, trajectory breaking it, the same just inside)
    ("lon_accel", traj(T20, a=-4.10), traj(T20, a=-4.00)),                                 # braking: > -4.05
    ("lon_accel", traj(T20, a=2.45), traj(T20, a=2.35)),                                   # accelerating: < 2.40
    ("lat_accel", traj(T20, yaw=0.49 * T20, yaw_rate=0.49), traj(T20, yaw=0.48 * T20, yaw_rate=0.48)),  # 10 x 0.49 = 4.9 > 4.89
    ("jerk", traj(T6, yaw=0.45 * T6 ** 2, yaw_rate=0.9 * T6),                              # |a| = 9 t: 9 > 8.37
     traj(T6, yaw=0.40 * T6 ** 2, yaw_rate=0.8 * T6)),
    ("lon_jerk", traj(T6, a=4.5 * T6), traj(T6, a=4.0 * T6)),                              # 4.5 > 4.13
    ("yaw_rate", traj(T20, v=1.0, yaw=1.0 * T20, yaw_rate=1.0), traj(T20, v=1.0, yaw=0.9 * T20, yaw_rate=0.9)),  # 1 > 0.95
    ("yaw_accel", traj(T5, yaw=1.0 * T5 ** 2), traj(T5, yaw=0.9 * T5 ** 2)),               # 2.0 > 1.93
]


@pytest.mark.parametrize("bound, outside, inside", COMFORT_CASES,
                         ids=["min_lon_accel", "max_lon_accel", "lat_accel", "jerk", "lon_jerk", "yaw_rate", "yaw_accel"])
def test_each_comfort_bound_breaks_alone(bound, outside, inside):
    within, _ = comfort_check(outside, ComfortBounds())
    assert not within[bound]
    assert all(ok for name, ok in within.items() if name != bound), within
    within, _ = comfort_check(inside, ComfortBounds())
    assert all(within.values()), within


def test_comfort_peaks_are_the_filtered_values():
    _, peaks = comfort_check(traj(T6, a=4.5 * T6), ComfortBounds())
    assert peaks["max_abs_lon_jerk"] == pytest.approx(4.5)
    assert peaks["max_lon_accel"] == pytest.approx(4.5 * 0.5)
    _, peaks = comfort_check(traj(T5, yaw=1.0 * T5 ** 2), ComfortBounds())
    assert peaks["max_abs_yaw_accel"] == pytest.approx(2.0) and peaks["max_abs_yaw_rate"] == pytest.approx(0.8)


# ------------------------------------------------------------------------------ at-fault collisions
EGO = State(t=0.0, x=0.0, y=0.0, yaw=0.0, v=10.0)
L, W, REAR = 4.5, 1.8, 1.4


def classify(ego: State, other: State) -> CollisionType:
    return collision_type(ego, L, W, REAR, other, L, W, SETTINGS.stopped_speed_m_s, SETTINGS.behind_angle_deg)


def test_collision_types_as_nuplan_orders_them():
    assert classify(EGO.replace(v=0.0), State(0, 4.4, 0.0, 0.0, 5.0)) == CollisionType.STOPPED_EGO
    assert classify(EGO, State(0, 4.4, 0.0, 0.0, 0.0)) == CollisionType.STOPPED_TRACK
    assert classify(EGO, State(0, -4.4, 0.0, 0.0, 15.0)) == CollisionType.ACTIVE_REAR        # 180 deg > 150
    assert classify(EGO, State(0, 4.4, 0.0, 0.0, 5.0)) == CollisionType.ACTIVE_FRONT
    assert classify(EGO, State(0, -1.0, 1.7, 0.0, 10.0)) == CollisionType.ACTIVE_LATERAL     # 77 deg, front edge clear


def test_who_is_at_fault():
    assert at_fault(CollisionType.ACTIVE_FRONT, False) and at_fault(CollisionType.STOPPED_TRACK, False)
    assert not at_fault(CollisionType.STOPPED_EGO, True) and not at_fault(CollisionType.ACTIVE_REAR, True)
    assert not at_fault(CollisionType.ACTIVE_LATERAL, ego_straddles_lanes=False)
    assert at_fault(CollisionType.ACTIVE_LATERAL, ego_straddles_lanes=True)


def test_collision_multiplier_per_kind():
    def hit(kind, fault=True):
        return Collision(7, kind, CollisionType.ACTIVE_FRONT, fault)

    assert collision_multiplier([], SETTINGS) == 1.0
    assert collision_multiplier([hit(RoadUserKind.VEHICLE)], SETTINGS) == 0.0            # 1 - 1/(0+1)
    assert collision_multiplier([hit(RoadUserKind.VRU)], SETTINGS) == 0.0
    assert collision_multiplier([hit(RoadUserKind.OBJECT)], SETTINGS) == 0.5             # 1 - 1/(1+1)
    assert collision_multiplier([hit(RoadUserKind.OBJECT)] * 2, SETTINGS) == 0.0
    assert collision_multiplier([hit(RoadUserKind.VEHICLE, fault=False)], SETTINGS) == 1.0


def test_straddling_lanes_is_judged_by_the_footprint_corners():
    lanes = LaneOccupancy(highway(lanes=2, segments=2).lanelet_network)
    y = lane_y(0)
    in_lane = np.array([[10, y + 0.8], [6, y + 0.8], [6, y - 0.8], [10, y - 0.8]])
    across_lanes = in_lane + [0, 1.2]
    across_segments = in_lane + [245, 0]          # the corners in lanelets 10 and 11, one after the other
    off_road = in_lane - [0, 2.0]
    assert not lanes.straddles_lanes(in_lane) and not lanes.straddles_lanes(across_segments)
    assert lanes.straddles_lanes(across_lanes) and lanes.straddles_lanes(off_road)


def test_drivable_area_multiplier():
    assert drivable_area_multiplier(Outcome.GOAL_REACHED, 0.0, 0.05, SETTINGS) == (1.0, 0.0)
    assert drivable_area_multiplier(Outcome.OFF_ROAD, 0.01, 0.05, SETTINGS) == (0.0, pytest.approx(0.06))
    # a loop that tolerates more than the score: 0.2 + 0.5 m beyond the road is past nuPlan's 0.3 m
    assert drivable_area_multiplier(Outcome.GOAL_REACHED, 0.2, 0.5, SETTINGS)[0] == 0.0
    assert drivable_area_multiplier(Outcome.GOAL_REACHED, 0.0, 0.5, SETTINGS)[0] == 1.0


# ------------------------------------------------------------------------------ direction, progress
@pytest.mark.parametrize("per_step, worst, multiplier", [(-0.15, 1.65, 1.0), (-0.3, 3.3, 0.5), (-0.6, 6.6, 0.0),
                                                         (0.5, 0.0, 1.0)])
def test_driving_against_the_lane_over_one_second(per_step, worst, multiplier):
    # nuPlan sums the progress of the 10 steps before each step and its own: 11 steps
    progress = np.concatenate([[0.0], np.full(20, per_step)])
    assert worst_wrong_way(progress, DT, 1.0) == pytest.approx(worst)
    assert direction_multiplier(worst_wrong_way(progress, DT, 1.0), SETTINGS) == multiplier


def test_reversing_along_a_lane_is_progress_against_its_direction():
    lanes = LaneOccupancy(highway(lanes=2, segments=1).lanelet_network)
    t = DT * np.arange(30)
    backwards = traj(t, x=100.0 - 3.0 * t, y=lane_y(0), v=3.0)            # lanelet 10 runs in +x
    ids = lanes.lane_of_each_step(backwards)
    assert set(ids) == {10}
    progress = lanes.progress_along_lanes(backwards, ids)
    assert progress[0] == 0.0 and np.allclose(progress[1:], -0.3)
    assert direction_multiplier(worst_wrong_way(progress, DT, 1.0), SETTINGS) == 0.5


@pytest.mark.parametrize("progress, goal, ratio", [(30, 100, 0.3), (1, 100, 0.02), (-3, 100, 0.0), (150, 100, 1.0),
                                                   (1, 1, 1.0)])
def test_progress_ratio(progress, goal, ratio):
    assert progress_ratio(progress, goal, 2.0) == pytest.approx(ratio)
    assert (progress_ratio(progress, goal, 2.0) >= SETTINGS.min_progress_ratio) == (ratio >= 0.2)


# ------------------------------------------------------------------------------ TTC, speed limit
def stopped_car(gap_m: float) -> RoadUser:
    x = L + gap_m          # centre to centre: half a car, the gap, half a car
    return RoadUser(9, RoadUserKind.VEHICLE, L, W, traj([0.0, 100.0], x=x, v=0.0))


@pytest.mark.parametrize("gap, ttc", [(9.95, 1.0), (8.95, 0.9), (30.5, math.inf)])
def test_time_to_collision_with_a_standing_car_ahead(gap, ttc):
    ego = traj([0.0], v=10.0)                      # 1 m per projection step of 0.1 s
    values = time_to_collision(ego, L, W, REAR, [stopped_car(gap)], 3.0, 0.1, 30.0, 150.0, 0.005, lambda k: False)
    assert values[0] == pytest.approx(ttc)
    assert (values[0] > SETTINGS.min_time_to_collision_s) == (ttc > 0.95)


def test_no_time_to_collision_when_standing_or_for_road_users_behind():
    assert time_to_collision(traj([0.0], v=0.0), L, W, REAR, [stopped_car(2.0)], 3.0, 0.1, 30.0, 150.0, 0.005,
                             lambda k: False)[0] == math.inf
    behind = RoadUser(9, RoadUserKind.VEHICLE, L, W, traj([0.0, 100.0], x=-10.0, v=20.0))
    assert time_to_collision(traj([0.0], v=10.0), L, W, REAR, [behind], 3.0, 0.1, 30.0, 150.0, 0.005,
                             lambda k: False)[0] == math.inf


def test_speed_limit_compliance_half_the_time_the_scale_over():
    t = DT * np.arange(101)                         # 10 s
    v = np.where(t < 5.0 - 1e-9, 10.0 + 2.23, 10.0)
    value, worst = speed_limit_compliance(t, v, np.full(len(t), 10.0), 2.23)
    assert value == pytest.approx(0.5) and worst == pytest.approx(2.23)
    assert speed_limit_compliance(t, v, np.full(len(t), np.nan), 2.23)[0] == 1.0       # no limit, no violation


def test_speed_limits_come_from_the_lanelets_traffic_signs():
    scenario = highway(lanes=1, segments=2)
    network = scenario.lanelet_network
    sign = TrafficSign(500, [TrafficSignElement(TrafficSignIDZamunda.MAX_SPEED, ["13.9"])], {10}, np.array([0.0, 0.0]))
    network.add_traffic_sign(sign, {10})
    network.add_traffic_sign(TrafficSign(501, [TrafficSignElement(TrafficSignIDZamunda.MAX_SPEED, ["72kmh"])], {11},
                                         np.array([250.0, 0.0])), {11})
    lanes = LaneOccupancy(network)
    ids = lanes.lane_of_each_step(traj([0.0, 1.0], x=[10.0, 400.0], y=lane_y(0)))
    assert list(ids) == [10, 11]
    assert list(lanes.speed_limits(ids)) == pytest.approx([13.9, 20.0])     # 72 km/h: as some converted maps write it
    assert math.isnan(LaneOccupancy(highway(lanes=1).lanelet_network).speed_limits(ids)[0])


# ------------------------------------------------------------------------------ the score
def test_score_is_the_multipliers_times_the_weighted_mean():
    ones = {name: 1.0 for name in ("at_fault_collisions", "drivable_area", "driving_direction", "making_progress",
                                   "progress", "time_to_collision", "speed_limit", "comfort")}
    assert combine(ones, ScoreWeights()) == 1.0
    assert combine(ones | {"comfort": 0.0}, ScoreWeights()) == pytest.approx(14 / 16)
    mixed = ones | {"progress": 0.5, "speed_limit": 0.25, "driving_direction": 0.5}
    assert combine(mixed, ScoreWeights()) == pytest.approx(0.5 * (5 * 0.5 + 5 + 4 * 0.25 + 2) / 16)
    for multiplier in ("at_fault_collisions", "drivable_area", "driving_direction", "making_progress"):
        assert combine(ones | {multiplier: 0.0}, ScoreWeights()) == 0.0


def test_a_score_drop_is_ranked_by_what_each_component_would_give_back():
    def agent(**components):
        full = {name: 1.0 for name in ("at_fault_collisions", "drivable_area", "driving_direction", "making_progress",
                                       "progress", "time_to_collision", "speed_limit", "comfort")} | components
        return AgentEvaluation(1, 10.0, 100.0, None, score=combine(full, ScoreWeights()), score_components=full)

    ideal, physical = agent(comfort=0.0), agent(comfort=0.0, time_to_collision=0.0, progress=0.8)
    drop, losses = score_drop(ideal, physical, ScoreWeights())
    assert drop == pytest.approx(14 / 16 - (5 * 0.8 + 4) / 16)
    assert [c.name for c in losses[:2]] == ["time_to_collision", "progress"]
    assert losses[0].regained == pytest.approx(5 / 16) and losses[1].regained == pytest.approx(5 * 0.2 / 16)
    assert all(c.regained == 0.0 for c in losses[2:])
