"""CommonRoad's reactive planner (commonroad-reactive-planner 2025.1) behind simgap's `Planner` protocol.

The upstream planner samples quartic (longitudinal) and quintic (lateral) polynomials in the
Frenet frame of a reference path, checks them against the vehicle's limits, sorts them by cost
and returns the cheapest one that a `pycrcc` collision checker finds free of the road boundary and
of the other traffic. This adapter builds everything it needs in code, once per agent:

* its configuration from our `Vehicle` and `ReactiveSettings` (no configuration file is read);
* the reference path: simgap's route centre line (`plan_reference_path`), handed to the planner's
  curvilinear coordinate system without upstream re-processing, so that arc lengths agree with
  simgap's speed profile;
* the road boundary (`create_road_boundary_obstacle`), built once;

and every cycle: a collision checker with the boundary and ``world.traffic`` (each participant's
prediction sampled at the plan's instants, as `collision.predict_traffic` does for the Frenet
planner), the desired speed (simgap's curvature-limited speed profile and goal approach, since the
upstream planner knows no lateral-acceleration bound), the observed state converted to the
planner's rear-axle state, the plan, and its conversion back to vehicle-centre states on the dt grid.

Upstream pitfalls worked around here:

* ``debug.multiproc`` defaults to True: every cycle would fork six processes. Switched off.
* ``set_desired_velocity(v, current_speed=0.0)`` ignores ``v`` and takes the planning problem's
  goal velocity (or initial speed: 0 at a standstill start, so it would never move off): the current
  speed handed over is at least `_MIN_REFERENCE_SPEED`.
* ``reset(initial_state_cart=...)`` converts the state to curvilinear coordinates with the low-speed
  mode of the previous cycle (``plan`` sets the mode afterwards): the mode is set before the reset.
* Its constructor edits the planning problem's initial state in place (deletes ``slip_angle``, adds
  ``acceleration``): it is given a copy.
* ``reset()`` without a collision checker rebuilds the road boundary from the scenario (tens of
  ms): the checker is always passed in.
* ``CoordinateSystem(path, preprocess_reference=False)`` without ``clcs_params`` fails
  (``None.default_proj_domain_limit``): default parameters are passed.
* The initial curvature comes from the steering angle: a physical car's road wheels turn further
  than a kinematic model's on the same path, so above `_KINEMATIC_STEER_SPEED` the steering angle of
  the path driven (from yaw rate and speed) is handed over instead.
* When no sample passes: one retry from zero acceleration and the reference path's curvature, then
  (``relax_steering_rate``) one without the steering-rate check, the tightest of the upstream checks
  (0.4 rad/s for the sedan), which a MuJoCo car drifting at a sharp curve's exit cannot meet.
* A state heading more than 90 degrees off the reference path raises a bare ``Exception``; an
  observed state outside the coordinate system's domain raises ``ValueError``: both are a failed
  cycle (None) with the reason in `failure_reason`.
"""

from __future__ import annotations

import copy
import math
import time
from dataclasses import dataclass

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from simgap.planning.collision import predict_traffic
from simgap.planning.protocol import Planner, PlannerSetup, PlanOutcome, World
from simgap.planning.reference_path import plan_reference_path
from simgap.planning.speed_profile import desired_speed, route_speeds
from simgap.trajectory import State, Trajectory

__all__ = ["ReactivePlanner", "ReactiveSettings"]

# the current speed handed to the upstream planner is at least this (see the module docstring)
_MIN_REFERENCE_SPEED = 0.01
# above this speed the initial curvature is taken from the yaw rate, below from the steering angle [m/s]
_KINEMATIC_STEER_SPEED = 1.0
# the reference path reaches this far beyond the horizon at the vehicle's top speed [m]
_PATH_MARGIN_M = 20.0


class ReactiveSettings(BaseModel):
    """Settings of CommonRoad's reactive planner as simgap exposes them."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    horizon_s: float = Field(3.0, gt=0, le=10, description="length of every plan [s] (upstream default 6 s)")
    t_min_s: float = Field(0.4, gt=0, description="shortest end time of a sampled manoeuvre [s]")
    sampling_levels: int = Field(
        3, ge=2, le=6, description="the upstream planner tries its sampling levels 1 .. sampling_levels - 1, "
                                   "each denser than the last, until one yields a plan (upstream default: 4)")
    lateral_range_m: float = Field(3.0, ge=0, le=10, description="lateral end offsets within +- this [m]")
    cruise_m_s: float = Field(10.0, gt=0, description="desired speed [m/s]; a faster start keeps its speed, "
                                                      "a goal velocity window above it raises it")
    max_lateral_acceleration: float = Field(
        4.0, gt=0, description="the desired speed is lowered where the reference path's curvature "
                               "would exceed this [m/s^2]")
    comfortable_deceleration: float = Field(2.0, gt=0, description="braking assumed ahead of curves and the goal "
                                                                   "[m/s^2]")
    lookahead_s: float = Field(3.0, ge=0, description="the desired speed is the lowest of the speed profile "
                                                      "this far ahead [s]")
    low_velocity_threshold_m_s: float = Field(
        4.0, ge=0, description="below this speed the lateral motion is planned over distance (upstream default)")
    relax_steering_rate: bool = Field(
        True, description="when no sample respects the steering-rate limit, one more attempt without it "
                          "(instead of braking in the lane)")
    traffic_margin_m: float = Field(0.3, ge=0, description="other traffic's footprints grown by this [m]")


@dataclass
class ReactiveCycle:
    """What one call of `ReactivePlanner.plan` did (for diagnostics and benchmarks)."""

    t: float = 0.0
    desired_speed: float = 0.0
    samples: int = 0
    rejected_kinematics: int = 0
    rejected_collision: int = 0
    relaxed: bool = False      # retried from zero acceleration and the reference's curvature
    steering_rate_relaxed: bool = False   # retried without the steering-rate limit
    outcome: PlanOutcome | None = None     # PLANNED, NO_PLAN or PROJECTION_FAILED; None until the cycle ends
    reason: str = ""
    seconds: float = 0.0


class ReactivePlanner(Planner):
    """CommonRoad's reactive planner (commonroad-reactive-planner 2025.1): Frenet polynomial samples
    along the route's reference path, checked against the vehicle's limits, the road boundary and
    the other traffic; one per agent, built in code (see the module docstring)."""

    Settings = ReactiveSettings

    def __init__(self, setup: PlannerSetup, settings: ReactiveSettings | None = None):
        # imported here: the upstream planner pulls in the drivability checker and omegaconf
        from commonroad.scenario.scenario import Scenario
        from commonroad_clcs.config import CLCSParams
        from commonroad_dc.boundary.boundary import create_road_boundary_obstacle
        from commonroad_rp.reactive_planner import ReactivePlanner as UpstreamPlanner
        from commonroad_rp.utility.utils_coordinate_system import CoordinateSystem

        self.settings = s = settings or ReactiveSettings()
        self.vehicle = vehicle = setup.vehicle
        self.dt = float(setup.dt)
        self.steps = max(1, int(round(s.horizon_s / self.dt)))
        scenario = Scenario(self.dt)
        scenario.add_objects(setup.lanelet_network)
        self._config = self._configuration(setup, scenario)
        reach = s.horizon_s * vehicle.limits.max_speed + _PATH_MARGIN_M
        self.reference_path = plan_reference_path(setup.lanelet_network, setup.planning_problem,
                                                  extension_back=reach, extension_forward=reach)
        self.speed_profile, self.approach = route_speeds(self.reference_path, setup, s.cruise_m_s,
                                                         s.max_lateral_acceleration, s.comfortable_deceleration,
                                                         vehicle.rear_axle_to_center)    # it plans the rear axle
        _, self._road_boundary = create_road_boundary_obstacle(scenario)
        self._upstream = UpstreamPlanner(self._config)
        self._upstream.set_reference_path(
            coordinate_system=CoordinateSystem(np.ascontiguousarray(self.reference_path.xy),
                                               preprocess_reference=False, clcs_params=CLCSParams()))
        self.last_cycle = ReactiveCycle()

    def _configuration(self, setup: PlannerSetup, scenario):
        from commonroad_rp.utility.config import ReactivePlannerConfiguration

        s, vehicle = self.settings, setup.vehicle
        config = ReactivePlannerConfiguration()
        v = config.vehicle
        v.length, v.width = vehicle.length, vehicle.width
        v.wb_rear_axle = vehicle.rear_axle_to_center
        v.wb_front_axle = vehicle.wheelbase - vehicle.rear_axle_to_center
        v.a_max, v.v_switch = vehicle.limits.max_accel, vehicle.limits.v_switch
        v.delta_min, v.delta_max = -vehicle.limits.max_steer, vehicle.limits.max_steer
        v.v_delta_min, v.v_delta_max = -vehicle.limits.max_steer_rate, vehicle.limits.max_steer_rate
        v._update_computed_params()
        p = config.planning
        p.dt, p.time_steps_computation = self.dt, self.steps
        p.planning_horizon = self.dt * self.steps
        p.low_vel_mode_threshold = s.low_velocity_threshold_m_s
        config.sampling.t_min = s.t_min_s
        config.sampling.d_min, config.sampling.d_max = -s.lateral_range_m, s.lateral_range_m
        config.sampling.num_sampling_levels = s.sampling_levels
        config.debug.multiproc = False
        config.debug.logging_level = "ERROR"
        config.debug.show_plots = config.debug.save_plots = False
        # a copy: the upstream planner edits the problem's initial state (drops its slip angle)
        config.update(scenario=scenario, planning_problem=copy.deepcopy(setup.planning_problem))
        return config

    @property
    def failure_reason(self) -> str:    # type: ignore[override]  # read-only: derived from the last cycle
        """Why the last cycle found no plan ("" after a plan)."""
        return self.last_cycle.reason

    def plan(self, observed: State, t: float, world: World) -> Trajectory | None:
        clock = time.perf_counter()
        cycle = ReactiveCycle(t=t)
        self.last_cycle = cycle
        try:
            return self._plan(observed, t, world, cycle)
        finally:
            cycle.seconds = time.perf_counter() - clock

    def _plan(self, observed: State, t: float, world: World, cycle: ReactiveCycle) -> Trajectory | None:
        if abs(float(world.dt) - self.dt) > 1e-9:
            raise ValueError(f"the reactive planner was set up for dt = {self.dt} s, the world has {world.dt} s")
        step = int(round(t / self.dt))
        checker = self._collision_checker(world, t, step)
        result = self._attempt(self._planner_state(observed, step), checker, t, cycle)
        if result is None and cycle.outcome == PlanOutcome.NO_PLAN:
            # nothing feasible from the observed acceleration and steering angle (physics may hand
            # over values no polynomial continues): once more from the observed pose and speed, with
            # zero acceleration and the reference path's curvature
            s_ref = float(self._upstream.x_0_cl[0][0])
            kappa = float(self.reference_path.polyline.interpolate(self.reference_path.kappa, s_ref))
            relaxed = self._planner_state(observed.replace(a=0.0), step,
                                          steer=math.atan(self.vehicle.wheelbase * kappa))
            cycle.relaxed = True
            result = self._attempt(relaxed, checker, t, cycle)
        if result is None and cycle.outcome == PlanOutcome.NO_PLAN and self.settings.relax_steering_rate:
            # still nothing: once more without the steering-rate limit (the tightest of the upstream
            # checks; a physical car that drifted needs more than a plan from the ideal state)
            checks = self._config.planning.constraints_to_check
            self._config.planning.constraints_to_check = [c for c in checks if c != "kappa_dot"]
            try:
                cycle.steering_rate_relaxed = True
                result = self._attempt(self._planner_state(observed, step), checker, t, cycle)
            finally:
                self._config.planning.constraints_to_check = checks
        if result is None:
            return None
        return self._trajectory(result[0].state_list, observed, t)

    def _attempt(self, start, checker, t: float, cycle: ReactiveCycle):
        """One upstream planning call from ``start``: its result, or None with the reason in ``cycle``."""
        up = self._upstream
        v = float(start.velocity)
        up._low_vel_mode = v < self.settings.low_velocity_threshold_m_s
        try:
            up.reset(initial_state_cart=start, initial_state_curv=None, collision_checker=checker)
        except Exception as exc:  # noqa: BLE001 - upstream raises a bare Exception for a reversed heading
            cycle.outcome, cycle.reason = PlanOutcome.PROJECTION_FAILED, f"observed state not on the reference path: {exc}"
            return None
        s_ref = float(up.x_0_cl[0][0])
        lookahead = max(v, 1.0) * self.settings.lookahead_s
        desired = desired_speed(self.speed_profile, self.approach, s_ref, t, v, lookahead).speed
        cycle.desired_speed = desired
        up.set_desired_velocity(desired_velocity=desired, current_speed=max(v, _MIN_REFERENCE_SPEED))
        result = up.plan()
        cycle.samples += up.total_count_samples
        cycle.rejected_kinematics += up.infeasible_count_kinematics
        cycle.rejected_collision += up.infeasible_count_collision
        if result is None:
            cycle.outcome = PlanOutcome.NO_PLAN
            cycle.reason = (f"no feasible collision-free sample: of {cycle.samples} samples "
                            f"{cycle.rejected_kinematics} beyond the vehicle's limits, "
                            f"{cycle.rejected_collision} colliding")
        else:
            cycle.outcome, cycle.reason = PlanOutcome.PLANNED, ""
        return result

    def _planner_state(self, observed: State, step: int, steer: float | None = None):
        """The observed (centre) state as the upstream planner's rear-axle state; its steering angle
        ``steer``, by default the one of the path the vehicle is on (`_kinematic_steer`)."""
        from commonroad_rp.state import ReactivePlannerState

        limits = self.vehicle.limits
        return ReactivePlannerState(
            time_step=step,
            position=np.array(self.vehicle.rear_axle_of(observed.x, observed.y, observed.yaw)),
            orientation=float(observed.yaw), velocity=max(float(observed.v), 0.0),
            acceleration=float(np.clip(observed.a, -limits.max_accel, limits.max_accel)),
            steering_angle=float(np.clip(self._kinematic_steer(observed) if steer is None else steer,
                                         -limits.max_steer, limits.max_steer)),
            yaw_rate=float(observed.yaw_rate))

    def _kinematic_steer(self, observed: State) -> float:
        """The steering angle of the path the vehicle is on (from its yaw rate when moving): the upstream
        planner starts its plan with that curvature, and a real car's wheels turn further than a
        kinematic model's on the same path."""
        if observed.v < _KINEMATIC_STEER_SPEED:
            return float(observed.steer)
        return math.atan(self.vehicle.wheelbase * observed.yaw_rate / observed.v)

    def _collision_checker(self, world: World, t: float, step: int):
        """The road boundary and every participant's footprint at the plan's time steps."""
        import commonroad_dc.pycrcc as pycrcc

        checker = pycrcc.CollisionChecker()
        checker.add_collision_object(self._road_boundary)
        if world.traffic:
            times = t + self.dt * np.arange(self.steps + 1)
            predicted = predict_traffic(world.traffic, times, lambda x, y: (x, y), 0.0,
                                        self.settings.traffic_margin_m)
            for k in range(len(predicted.half_length)):
                tvo = pycrcc.TimeVariantCollisionObject(step)
                for i in range(len(times)):
                    tvo.append_obstacle(pycrcc.RectOBB(float(predicted.half_length[k]),
                                                       float(predicted.half_width[k]), float(predicted.yaw[k, i]),
                                                       float(predicted.x[k, i]), float(predicted.y[k, i])))
                checker.add_collision_object(tvo)
        return checker

    def _trajectory(self, states, observed: State, t: float) -> Trajectory:
        """Upstream rear-axle states -> simgap centre states from ``observed`` on the dt grid."""
        yaw = np.unwrap(np.array([float(st.orientation) for st in states]))
        yaw += 2.0 * math.pi * round((observed.yaw - yaw[0]) / (2.0 * math.pi))   # the observed yaw's branch
        x, y = self.vehicle.centre_of(np.array([float(st.position[0]) for st in states]),
                                      np.array([float(st.position[1]) for st in states]), yaw)
        n = len(states)
        columns = dict(
            t=t + self.dt * np.arange(n), x=x, y=y, yaw=yaw,
            v=np.array([float(st.velocity) for st in states]),
            a=np.array([float(st.acceleration) for st in states]),
            yaw_rate=np.array([float(st.yaw_rate) for st in states]),
            steer=np.array([float(st.steering_angle) for st in states]))
        # the plan starts exactly at the observed state (upstream recomputes it from the polynomials)
        for name in ("x", "y", "yaw", "v"):
            columns[name][0] = getattr(observed, name)
        return Trajectory(self.dt, **columns)
