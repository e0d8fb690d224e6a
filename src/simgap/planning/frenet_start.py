"""Stage 1 of a cycle of the Frenet planner (`simgap.planning.frenet`): the observed state
projected into the Frenet frame of the reference path, and the speed the cycle aims at → `Start`;
and the same start relaxed (zero acceleration, the reference's curvature) when nothing is feasible
from the observed acceleration and steering."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from simgap.planning.frenet_cycle import PlanningCycle, Start
from simgap.planning.frenet_frame import FrenetFrame
from simgap.planning.settings import FrenetSettings
from simgap.planning.speed_profile import GoalApproach, SpeedProfile, desired_speed
from simgap.scenario.goal import Goal
from simgap.trajectory import State

# no overtaking within this distance of the goal (or the speed lookahead, when longer) [m]
NO_OVERTAKING_BEFORE_GOAL_M = 15.0


class StartProjection:
    """Where a cycle starts, in the Frenet frame, and the speed it aims at."""

    def __init__(self, vehicle, settings: FrenetSettings, frame: FrenetFrame, speed_profile: SpeedProfile):
        self.vehicle, self.settings, self.frame, self.speed_profile = vehicle, settings, frame, speed_profile

    def project(self, observed: State, t: float, dt: float, cycle: PlanningCycle, approach: GoalApproach,
                goal: Goal) -> Start | None:
        """The observed state projected into the Frenet frame, and the speed to aim at (None: it
        cannot be projected)."""
        v = max(float(observed.v), 0.0)
        low_velocity = v < self.settings.sampling.low_velocity_threshold_m_s
        cycle.low_velocity = low_velocity
        x_rear, y_rear = self.frame.xy_to_local(*self.vehicle.rear_axle_of(observed.x, observed.y, observed.yaw))
        yaw_local = self.frame.local_heading(observed.yaw)
        limits = self.vehicle.limits
        a0 = float(np.clip(observed.a, -limits.max_accel, limits.max_accel))
        steer0 = float(np.clip(observed.steer, -limits.max_steer, limits.max_steer))
        try:
            x0_lon, x0_lat = self.frame.initial_state(float(x_rear), float(y_rear), yaw_local, v, a0, steer0,
                                                      self.vehicle.wheelbase, low_velocity)
        except (RuntimeError, ValueError):
            return None
        s_ref = float(self.frame.to_reference_s(x0_lon[0]))
        lookahead = max(v, 1.0) * self.settings.speed.lookahead_s
        aim = desired_speed(self.speed_profile, approach, s_ref, t, v, lookahead)
        desired = aim.speed
        cycle.desired_speed = desired
        may_overtake = approach.distance_to_goal(s_ref) > max(lookahead, NO_OVERTAKING_BEFORE_GOAL_M)
        speed = self.settings.speed
        bound = speed.late_lateral_acceleration if aim.late else speed.max_lateral_acceleration
        in_reach = self._goal_in_reach(goal, observed, t, max(v, desired))
        return Start(t, dt, x0_lon, x0_lat, float(x_rear), float(y_rear), yaw_local, v, desired, low_velocity,
                     may_overtake, bound, in_reach)

    def relaxed(self, start: Start) -> Start | None:
        """``start`` with zero acceleration and the reference path's curvature."""
        _, kappa_ref, _ = self.frame.reference_at(np.array([start.x0_lon[0]]))
        steer_ref = math.atan(self.vehicle.wheelbase * float(kappa_ref[0]))
        try:
            x0_lon, x0_lat = self.frame.initial_state(start.x_rear, start.y_rear, start.yaw_local, start.v, 0.0,
                                                      steer_ref, self.vehicle.wheelbase, start.low_velocity)
        except (RuntimeError, ValueError):
            return None
        return replace(start, x0_lon=x0_lon, x0_lat=x0_lat)

    def _goal_in_reach(self, goal: Goal, observed: State, t: float, speed: float) -> bool:
        """Might a plan from ``observed`` at ``t`` reach a goal state within the horizon: its time
        window overlaps the horizon and its position lies within the distance driven at ``speed``
        (and a car's length) of the vehicle's centre?"""
        horizon = self.settings.sampling.horizon_s
        reach = speed * horizon + self.vehicle.length
        return any((gs.time is None or (gs.time.lo <= t + horizon and gs.time.hi >= t))
                   and gs.distance_from_position(observed.x, observed.y) <= reach
                   for gs in goal.states)
