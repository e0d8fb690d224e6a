"""The desired speed along the reference path.

A cruise speed (the configured default, or faster when the start or the goal's velocity window
asks for it), lowered wherever the reference path's curvature would push the lateral acceleration
v^2 * kappa over the bound or where it changes faster than the steering can follow (a given
steering rate), and lowered ahead of such places so that a comfortable deceleration
reaches them in time. `GoalApproach` then aims the arrival at the goal: inside its velocity
window (braking towards it at the comfortable deceleration) and not before its time window
(slowing to the average speed that arrives in time, down to waiting at the goal).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import shapely
from commonroad.planning.goal import GoalRegion
from commonroad.scenario.lanelet import LaneletNetwork

from simgap.planning.protocol import PlannerSetup
from simgap.planning.reference_path import ReferencePath
from simgap.scenario.goal import Goal, Window, area_of
from simgap.trajectory import DEFAULT_TIME_STEP_S

if TYPE_CHECKING:
    from simgap.vehicles.catalogue import Vehicle

# the profile aims at this share of the lateral-acceleration bound, leaving room for plans
# whose curvature overshoots the reference path's while they converge onto it
_LATERAL_ACCELERATION_SHARE = 0.85
# the steering-rate limit never asks for less than this [m/s]
_STEERING_SPEED_FLOOR = 1.0


# a target inside a window keeps this share of the window's width from its bounds
_WINDOW_INSET = 0.1
# the arrival is aimed this far into the time window (at most ``_TIME_AIM_MAX_S``), from either
# end: a planned speed lags the desired one, and a late or early arrival still falls inside; a
# window shorter than twice that (a recorded driver's end time, +-0.2 s) is aimed at its middle
_TIME_AIM_SHARE = 0.5
_TIME_AIM_MAX_S = 1.0
# the planned speed follows the desired one with a lag: the velocity window is aimed this long ahead
_RESPONSE_S = 1.0
# the pace to an early time window is bracketed twice among this many speeds up to the path's limit
_PACE_CANDIDATES = 32
# a goal whose centre lies farther than this from the reference path is not aimed at
_GOAL_ON_PATH_M = 20.0


def target_in(window: Window, default: float) -> float:
    """``default`` moved inside ``window`` (``_WINDOW_INSET`` of its width from the bounds)."""
    inset = _WINDOW_INSET * max(window.hi - window.lo, 0.0)
    return float(np.clip(default, window.lo + inset, window.hi - inset))


def cruise_speed(goal: GoalRegion | None, default: float, max_speed: float, initial_speed: float = 0.0,
                 dt: float = DEFAULT_TIME_STEP_S) -> float:
    """The cruise speed: the default, or the initial speed when faster (a highway start keeps its
    speed), raised into the goal's velocity window when that lies above; capped at ``max_speed``."""
    speed = max(default, initial_speed)
    window = Goal.of(goal, dt).velocity_window() if goal is not None else None
    if window is not None and window.lo > speed:
        speed = target_in(window, speed)
    return float(min(max(speed, 0.0), max_speed))


class GoalApproach:
    """A cap on the desired speed that puts the vehicle inside the goal when its windows are open.

    The goal's position is a stretch of the reference path (``enter`` to ``exit`` arc length: the
    reference points inside it, or the point nearest a goal centre off the path). The vehicle
    brakes into the velocity window before it enters the stretch and keeps to it until the stretch
    ends. Before the time window opens it drives no faster than the pace that reaches the hold
    point (`HOLD_MARGIN_M` before the stretch's end or, when it is shorter, where the vehicle's
    centre is at its middle) when the window opens — slower where the path's limit asks for it
    (a turn on the way is made up for elsewhere), up to speed for the velocity window a response
    time before (`_pace`): arrived early, it stops there and waits. Late,
    it drives at least as fast as entering the stretch before the window closes needs
    (`speed_floor`), turning harder (the late limit) when the path's limit would make it too late.
    A goal that is a time window alone, on a road that ends before the window opens, is waited for
    before the road's end.
    """

    def __init__(self, reference: ReferencePath, goal: Goal, cruise: float, deceleration: float,
                 top_speed: float = math.inf, centre_ahead_m: float = 0.0, limit: np.ndarray | None = None,
                 road_end: float | None = None, late_limit: np.ndarray | None = None):
        """``centre_ahead_m``: how far the vehicle's centre (where the goal is judged) lies ahead of
        the point whose arc length the planner passes (its rear axle: the wheelbase's rear part).
        ``limit``: the path's speed limit over ``reference.s`` (`SpeedProfile.limit`), which the
        pace to an early time window drives within, and ``late_limit`` (`SpeedProfile.late_limit`)
        the one a vehicle that cannot enter the goal in time within ``limit`` drives within.
        ``road_end``: where that point is when the vehicle's front reaches the end of the mapped
        road (the route's dead end), if it has one: a goal that is a time window alone (no
        position on the path) is waited for before it."""
        self.stretch = _goal_stretch(reference, goal)
        self.s = reference.s
        self.limit = np.minimum(limit if limit is not None else np.full(len(reference.s), math.inf), top_speed)
        self.late_limit = None if late_limit is None else np.minimum(late_limit, top_speed)
        self.centre_ahead = centre_ahead_m
        velocity, time = goal.velocity_window(), goal.time_window()
        self.arrival_speed = target_in(velocity, cruise) if velocity is not None else None
        # the slowest speed the vehicle may arrive at (the velocity window's lower bound, inset)
        self.slowest_arrival = target_in(velocity, 0.0) if velocity is not None and velocity.lo > 0 else 0.0
        self.arrival_time = (None if time is None else
                             time.lo + min(_TIME_AIM_SHARE * (time.hi - time.lo), _TIME_AIM_MAX_S))
        self.latest_arrival = (None if time is None else
                               time.hi - min(_TIME_AIM_SHARE * (time.hi - time.lo), _TIME_AIM_MAX_S))
        self.deceleration = deceleration
        self.top_speed = top_speed
        self.road_end = road_end if self.stretch is None and time is not None else None
        # a time window alone is met then (inf: no time window; `road_end` is None then)
        self.window_opens = time.lo if time is not None else math.inf

    def distance_to_goal(self, s: float) -> float:
        """Arc length from ``s`` to the goal's stretch (0 inside it; inf: no goal on the path, or passed)."""
        if self.stretch is None or s > self.stretch[1]:
            return math.inf
        return max(self.stretch[0] - s, 0.0)

    def speed_floor(self, s: float, t: float, cruise: float) -> tuple[float, bool]:
        """The lowest cruise speed that still enters the goal's stretch (`ENTRY_DEPTH_M` into it)
        before its time window closes, driving within the path's limit on the way (a turn is made
        up for elsewhere), and whether the vehicle is late: that speed lies above ``cruise``, and
        it is the late limit it drives within (0: no time window, or already in the stretch)."""
        if self.stretch is None or self.latest_arrival is None or s >= self.stretch[0] or t >= self.latest_arrival:
            return 0.0, False
        enter, leave = self.stretch
        target = enter + min(ENTRY_DEPTH_M, 0.5 * (leave - enter))
        pace = self._pace(s, target, self.latest_arrival - t)
        if pace > cruise and self.late_limit is not None:
            return min(self._pace(s, target, self.latest_arrival - t, self.late_limit), self.top_speed), True
        return min(pace, self.top_speed), False

    def speed_cap(self, s: float, t: float, v: float) -> float:
        """The highest desired speed at arc length ``s``, time ``t`` and speed ``v`` (inf: no cap)."""
        if self.road_end is not None and t < self.window_opens:
            # a time window alone on a road that ends: the pace that reaches the road's end when the
            # window opens, braking (at the comfortable rate) to stand there before
            braking = max(self.road_end - s - v * _RESPONSE_S, 0.0)
            return min(math.sqrt(2.0 * self.deceleration * braking),
                       self._pace(s, max(self.road_end, s), self.window_opens - t))
        if self.stretch is None or s > self.stretch[1]:
            return math.inf
        enter, leave = self.stretch
        cap = math.inf
        if self.arrival_speed is not None:
            braking = max(enter - s - v * _RESPONSE_S, 0.0)
            cap = math.sqrt(self.arrival_speed**2 + 2.0 * self.deceleration * braking)
        if self.arrival_time is not None and t < self.arrival_time:
            hold = max(0.5 * (enter + leave) - self.centre_ahead, leave - HOLD_MARGIN_M)
            cap = min(cap, self._pace(s, max(hold, s), self.arrival_time - t))
        return cap

    def _pace(self, s: float, hold: float, duration: float, limit: np.ndarray | None = None) -> float:
        """The speed ``v`` to drive at now so as to reach arc length ``hold`` from ``s`` in
        ``duration``, driving along the way at v, or slower where the path's limit asks for it, and
        raised (at the comfortable rate) to the slowest arrival the velocity window allows
        `_RESPONSE_S` before ``hold`` (the planned speed lags the desired one); inf when even the
        limit is too slow (late: `speed_floor`'s business)."""
        x = np.concatenate(([s], self.s[(self.s > s) & (self.s < hold)], [hold]))
        if x[-1] - x[0] < 1e-6:
            return 0.0
        limit = np.interp(x, self.s, self.limit if limit is None else limit)
        w, a = self.slowest_arrival, self.deceleration
        raised = np.sqrt(np.maximum(w * w - 2.0 * a * np.maximum(hold - w * _RESPONSE_S - x, 0.0), 0.0))
        step = np.diff(x)

        def times(v: np.ndarray) -> np.ndarray:           # falls as v rises
            inverse = 1.0 / np.maximum(np.minimum(limit, np.maximum(v[:, None], raised)), 1e-3)
            return ((inverse[:, 1:] + inverse[:, :-1]) * 0.5 * step).sum(axis=1)

        top = float(limit.max())
        if not math.isfinite(top):                         # no limit: well above any pace that arrives in time
            top = 4.0 * (x[-1] - x[0]) / duration + w
        v = top * (np.arange(1, _PACE_CANDIDATES + 1) / _PACE_CANDIDATES) ** 2
        for _ in range(2):                                 # a coarse bracket, then a fine one
            spent = times(v)
            if spent[-1] > duration:
                return math.inf
            k = int(np.argmax(spent <= duration))
            if k == 0:
                return float(v[0]) * float(spent[0]) / duration     # slower than the slowest candidate
            lo, hi, t_lo, t_hi = v[k - 1], v[k], spent[k - 1], spent[k]
            v = np.linspace(lo, hi, _PACE_CANDIDATES)
        # between the two, the time is close to linear in 1 / v (exactly so when v is held throughout)
        share = (t_lo - duration) / (t_lo - t_hi)
        return float(1.0 / (1.0 / lo + share * (1.0 / hi - 1.0 / lo)))


# a late vehicle aims this far into the goal's stretch of the path when its time window is closing [m]
ENTRY_DEPTH_M = 3.0
# an early arrival waits this far before the end of the goal's stretch of the path [m] (the planner's
# arc length is the rear axle's; the goal is judged at the vehicle's centre, a metre or two ahead)
HOLD_MARGIN_M = 4.0
# a vehicle waiting for a goal's time window at the end of the mapped road stands this far before it [m]
ROAD_END_MARGIN_M = 1.0


def _goal_stretch(reference: ReferencePath, goal: Goal) -> tuple[float, float] | None:
    """(enter, exit) arc length of the first goal state's position along ``reference``: the first
    run of reference points inside it (from the route's start on), else the point nearest a goal
    centre within `_GOAL_ON_PATH_M` (enter = exit); None when no goal position lies on the path."""
    ahead = reference.s >= reference.route_s[0]
    for state in goal.states:
        if state.position is None:
            continue
        inside = shapely.contains_xy(area_of(state.position), reference.xy[:, 0], reference.xy[:, 1]) & ahead
        if inside.any():
            first = int(np.argmax(inside))
            after = np.flatnonzero(~inside[first:])
            last = first + (int(after[0]) - 1 if len(after) else len(inside) - first - 1)
            return float(reference.s[first]), float(reference.s[last])
        for centre in state.centres():
            distance = np.hypot(reference.xy[:, 0] - centre[0], reference.xy[:, 1] - centre[1])
            k = int(distance.argmin())
            if distance[k] <= _GOAL_ON_PATH_M:
                return float(reference.s[k]), float(reference.s[k])
    return None


class SpeedProfile:
    """Desired speed at every reference point (array ``v`` over ``reference.s``): the cruise speed,
    lowered by the limits of the path (array ``limit``: curvature, steering rate, and braking
    ahead of both); ``late_limit`` the same at a higher lateral acceleration, for a vehicle late
    for its goal's time window (None when there is none higher)."""

    def __init__(self, reference: ReferencePath, cruise: float, max_lateral_acceleration: float,
                 comfortable_deceleration: float, steering: tuple[float, float] | None = None,
                 late_lateral_acceleration: float | None = None):
        """``steering``: (wheelbase [m], steering rate [rad/s]) to keep the curvature's change
        within: the road-wheel angle atan(wheelbase * kappa) changes at
        wheelbase * v * dkappa/ds / (1 + (wheelbase * kappa)^2)."""
        self.reference = reference
        self.cruise = cruise
        self.limit = _path_limit(reference, max_lateral_acceleration, comfortable_deceleration, steering)
        self.late_limit = None
        if late_lateral_acceleration is not None and late_lateral_acceleration > max_lateral_acceleration:
            self.late_limit = _path_limit(reference, late_lateral_acceleration, comfortable_deceleration, steering)
        # braking ahead of a constant cruise speed changes nothing: min(cruise, limit) is the profile
        self.v = np.minimum(self.limit, cruise)
        self.v.flags.writeable = False

    def desired_speed(self, s: float, distance: float, cruise: float | None = None, late: bool = False) -> float:
        """The lowest desired speed between ``s`` and ``s + distance`` (reference arc length); with
        ``cruise``, as if the profile had been built for that cruise speed (``late``: within
        ``late_limit``)."""
        ref_s = self.reference.s
        lo = int(np.searchsorted(ref_s, s, side="right")) - 1
        hi = int(np.searchsorted(ref_s, s + max(distance, 0.0), side="right"))
        lo, hi = max(lo, 0), min(max(hi, lo + 1), len(ref_s))
        limits = self.v if cruise is None else self.late_limit if late and self.late_limit is not None \
            else self.limit
        here = float(np.interp(s, ref_s, limits))
        speed = float(min(here, limits[lo:hi].min()))
        return speed if cruise is None else min(speed, cruise)


def _path_limit(reference: ReferencePath, max_lateral_acceleration: float, comfortable_deceleration: float,
                steering: tuple[float, float] | None) -> np.ndarray:
    """The speed limit at every reference point: curvature, steering rate, and braking ahead of both."""
    kappa = np.maximum(np.abs(reference.kappa), 1e-9)
    limit = np.sqrt(_LATERAL_ACCELERATION_SHARE * max_lateral_acceleration / kappa)
    if steering is not None and len(reference.s) > 2:
        wheelbase, steer_rate = steering
        change = np.abs(np.gradient(reference.kappa, reference.s)) * wheelbase
        limit = np.minimum(limit, np.maximum(steer_rate * (1.0 + (wheelbase * kappa) ** 2) / np.maximum(change, 1e-9),
                                             _STEERING_SPEED_FLOOR))
    ds = np.diff(reference.s)
    for i in range(len(limit) - 2, -1, -1):
        limit[i] = min(limit[i], np.sqrt(limit[i + 1] ** 2 + 2.0 * comfortable_deceleration * ds[i]))
    limit.flags.writeable = False
    return limit


@dataclass(frozen=True)
class DesiredSpeed:
    """The speed a planning cycle aims at, and whether it is late for the goal's time window
    (then plans may turn at the late lateral acceleration)."""

    speed: float
    late: bool = False


def desired_speed(profile: SpeedProfile, approach: GoalApproach, s: float, t: float, v: float,
                  lookahead: float) -> DesiredSpeed:
    """The speed a planner aims at, at arc length ``s``, time ``t`` and speed ``v``: the profile's
    lowest within ``lookahead`` metres, its cruise speed raised as far as the goal's time window
    needs (`GoalApproach.speed_floor`; late, within the profile's late limit), capped by the goal's
    approach (`GoalApproach.speed_cap`)."""
    floor, late = approach.speed_floor(s, t, profile.cruise)
    cruise = max(profile.cruise, floor)
    return DesiredSpeed(min(profile.desired_speed(s, lookahead, cruise, late), approach.speed_cap(s, t, v)), late)


def route_speeds(reference: ReferencePath, setup: PlannerSetup, cruise_m_s: float, max_lateral_acceleration: float,
                 comfortable_deceleration: float, centre_ahead_m: float = 0.0) -> tuple[SpeedProfile, GoalApproach]:
    """The speed profile along ``reference`` (cruise speed from the goal's velocity window and the
    vehicle's top speed) and the approach to the goal's time window, for the agent ``setup`` builds."""
    problem = setup.planning_problem
    initial_speed = float(getattr(problem.initial_state, "velocity", 0.0) or 0.0)
    cruise = cruise_speed(problem.goal, cruise_m_s, setup.vehicle.limits.max_speed, initial_speed)
    profile = SpeedProfile(reference, cruise, max_lateral_acceleration, comfortable_deceleration)
    return profile, goal_approach(reference, Goal.of(problem.goal, setup.dt), profile, comfortable_deceleration,
                                  setup.vehicle, setup.lanelet_network, centre_ahead_m)


def goal_approach(reference: ReferencePath, goal: Goal, profile: SpeedProfile, comfortable_deceleration: float,
                  vehicle: Vehicle, network: LaneletNetwork, centre_ahead_m: float = 0.0) -> GoalApproach:
    """The approach to ``goal`` along ``reference`` within ``profile``'s limits (and its late
    limit), for ``vehicle`` whose planned point lies ``centre_ahead_m`` behind its centre, standing
    short of the mapped road's end where the route has one (`ReferencePath.dead_end`)."""
    end = reference.dead_end(network)
    road_end = None if end is None else end - (centre_ahead_m + vehicle.length / 2.0 + ROAD_END_MARGIN_M)
    return GoalApproach(reference, goal, profile.cruise, comfortable_deceleration, vehicle.limits.max_speed,
                        centre_ahead_m, profile.limit, road_end, profile.late_limit)
