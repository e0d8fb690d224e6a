"""The Frenet sampling planner on the frenetix core.

Every cycle: project the observed state into the Frenet frame of the reference path → sample end
time x end speed x lateral offset → in the core's cost order, a few at a time, check plans against
the road's edge, other traffic and the lateral-acceleration bound → return the first that passes,
converted to simgap's convention (vehicle centre, world frame) on the dt grid from the observed
time. The core generates the quartic (longitudinal) and quintic (lateral) polynomials, fills in
Cartesian coordinates, checks feasibility against the vehicle's limits and computes costs only for
the samples the cycle looks at and those that might come before them (`cost_order`): the order
is the one the core gives when it evaluates every sample.

Beyond the core:

* Acceleration and curvature are re-checked from exact values (the core derives them from
  halved second derivatives, see `frenet_frame`).
* The manoeuvre chosen last cycle is sampled again (same end time, speed and offset): from the
  state it predicted it is exactly its own remainder, so a plan once found stays available.
* With traffic around, a plan must end where braking at ``collision.stopping_deceleration``
  along the path stays clear of traffic as it stands at the horizon's end; without this, a
  3 s horizon happily drives up to a parked car too fast to stop.
* Plans that exceed the lateral-acceleration bound are taken only when nothing else passes.
* Near the goal (its time window within the horizon, its area within reach), a plan that reaches
  it — every window of a goal state at one of the plan's states — is preferred to a cheaper one
  that passes beside it, too early or too fast (a recorded goal is often a 2 m box with an
  orientation window around where the human driver was).
* When nothing is feasible from the observed acceleration and steering angle (physics may
  hand over values no polynomial continues), one retry starts from the observed pose and speed
  with zero acceleration and the reference's curvature (``relax_initial_state``).
* A physical car tracks its plan with centimetre errors: while it is within
  ``continue_plan_within_m`` of the last plan, the next one starts from that plan's state (the
  controller corrects the error); a car near the road's edge but on the road is never planned
  further out (`_RoadLeeway`); the desired speed leaves part of the steering rate unused
  (`STEER_RATE_SHARE`), and plans beyond the steering rate are a last resort.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace

import frenetix
import frenetix.trajectory_functions as trajectory_functions
import frenetix.trajectory_functions.cost_functions as cost_functions
import frenetix.trajectory_functions.feasability_functions as feasibility_functions
import numpy as np

from simgap.planning.cost_order import CoreReference, CostOrder, cost_floor
from simgap.planning.collision import (
    DrivableAreaGrid,
    RoadBand,
    TrafficPrediction,
    footprint_outline,
    footprints_on_road,
    predict_traffic,
    struck_from_behind,
    traffic_collisions,
    traffic_overlaps,
)
from simgap.planning.frenet_frame import CartesianBatch, FrenetFrame
from simgap.planning.protocol import PlannerSetup, PlanOutcome, World
from simgap.planning.reference_path import ReferencePath, plan_reference_path
from simgap.planning.sampling import (
    END_OFFSET,
    END_SPEED,
    END_TIME,
    TIME_NUDGE,
    end_speeds,
    end_times,
    lateral_offsets,
    sampling_matrix,
    steps_in_horizon,
)
from simgap.planning.settings import FrenetSettings
from simgap.planning.speed_profile import GoalApproach, SpeedProfile, cruise_speed, desired_speed, goal_approach
from simgap.scenario.goal import Goal
from simgap.trajectory import State, Trajectory, wrap_angle

__all__ = ["FrenetPlanner", "FrenetSettings", "PlanningCycle"]

PHASES = ("projection", "sampling", "evaluation", "collision", "conversion")

# plans are checked in cost order in chunks growing from FIRST_CHUNK to MAX_CHUNK
FIRST_CHUNK, MAX_CHUNK = 4, 64
# when traffic blocks the cheapest plan (settings.speed.blocked_speed_share), a plan faster by
# BLOCKED_SPEED_GAIN x the desired speed is looked for among this many more samples
BLOCKED_SPEED_GAIN = 0.2
BLOCKED_SEARCH_SAMPLES = 256
# ... except within this distance of the goal (or the speed lookahead, when longer) [m]
NO_OVERTAKING_BEFORE_GOAL_M = 15.0
# a vehicle whose footprint grown by this much leaves the road is at the road's edge [m]
ROAD_EDGE_M = 0.3
# the desired speed asks for at most this share of the vehicle's steering rate where the curvature
# changes: a physical car needs the rest to correct its tracking errors
STEER_RATE_SHARE = 0.85
# the next plan continues the last one when the vehicle is this close to it (and within
# settings.continue_plan_within_m) [rad], [m/s]
CONTINUE_PLAN_HEADING, CONTINUE_PLAN_SPEED = 0.1, 1.0


@dataclass(frozen=True)
class _Start:
    """Where a planning cycle starts: the observed state in the Frenet frame (core layout:
    ``x0_lon`` = s, s_dot, s_ddot; ``x0_lat`` = d, d_dot, d_ddot), the rear axle in the local
    frame, and the speed the cycle aims at."""

    t: float
    dt: float
    x0_lon: np.ndarray
    x0_lat: np.ndarray
    x_rear: float
    y_rear: float
    yaw_local: float
    v: float
    desired: float
    low_velocity: bool
    may_overtake: bool = True     # not when the goal is near: it is entered behind slower traffic
    lateral_bound: float = math.inf   # plans within this lateral acceleration are preferred [m/s^2]
    goal_in_reach: bool = False   # a plan may reach the goal within the horizon: one that does is preferred


@dataclass(frozen=True)
class _RoadLeeway:
    """How a plan may use the road's edge when the vehicle is not safely on the road now: for
    ``steps`` after the present it may leave the safe cells but must keep within ``band`` (the
    band the vehicle is in now; None when it is off the road already: anywhere). After them
    every plan is on the safe cells."""

    steps: int = 0
    band: RoadBand | None = RoadBand.SAFE


@dataclass
class PlanningCycle:
    """What one call of `FrenetPlanner.plan` did (for diagnostics and benchmarks)."""

    t: float = 0.0
    samples: int = 0
    evaluated: int = 0         # samples the core evaluated (in its cost order, as they were looked at)
    feasible: int = 0          # feasible among them
    floor_misses: int = 0      # samples whose cost came out below cost_order's floor (none, or a bug)
    checked: int = 0
    rejected_infeasible: int = 0
    rejected_road: int = 0
    rejected_traffic: int = 0
    rejected_lateral_acceleration: int = 0
    low_velocity: bool = False
    relaxed: bool = False
    desired_speed: float = 0.0
    outcome: PlanOutcome | None = None     # None until the cycle ends
    timings: dict[str, float] = field(default_factory=lambda: {p: 0.0 for p in PHASES})


class FrenetPlanner:
    """The paper's planner: Frenet sampling on the frenetix core, end time x end speed x lateral
    offset along the route's reference path, checked against road, traffic and vehicle limits.

    Built once per agent: the reference path from ``planning_problem``'s route, the Frenet
    frame, the drivable-area grid and the speed profile. ``plan`` accepts any observed state
    (moving, off-centre, with a heading error) and returns a `Trajectory` of
    ``horizon / dt + 1`` states from the observed time, or None when no sampled plan is
    feasible and collision-free.
    """

    Settings = FrenetSettings

    def __init__(self, setup: PlannerSetup, settings: FrenetSettings | None = None):
        vehicle, lanelet_network, planning_problem = setup.vehicle, setup.lanelet_network, setup.planning_problem
        self.vehicle = vehicle
        self.settings = settings or FrenetSettings()
        s = self.settings
        horizon_reach = s.sampling.horizon_s * vehicle.limits.max_speed + 20.0
        extension = s.reference_path.extension_m or horizon_reach
        self.reference_path: ReferencePath = plan_reference_path(
            lanelet_network, planning_problem, spacing=s.reference_path.spacing_m,
            smoothing=s.reference_path.smoothing_m, extension_back=s.reference_path.extension_back_m,
            extension_forward=extension)
        self.frame = FrenetFrame(self.reference_path)
        self.goal = planning_problem.goal
        initial_speed = float(getattr(planning_problem.initial_state, "velocity", 0.0) or 0.0)
        self.cruise_speed = cruise_speed(planning_problem.goal, s.speed.cruise_m_s, vehicle.limits.max_speed,
                                         initial_speed)
        self.speed_profile = SpeedProfile(self.reference_path, self.cruise_speed,
                                          s.speed.max_lateral_acceleration, s.speed.comfortable_deceleration,
                                          (vehicle.wheelbase, STEER_RATE_SHARE * vehicle.limits.max_steer_rate),
                                          s.speed.late_lateral_acceleration)
        self._network = lanelet_network
        route_end = np.asarray(lanelet_network.find_lanelet_by_id(
            self.reference_path.lanelet_ids[-1]).center_vertices[-1]) if self.reference_path.lanelet_ids \
            else self.reference_path.xy[-1]
        corridor = self.frame.points_to_local(self.reference_path.xy)
        self.drivable_area = DrivableAreaGrid.for_route(
            lanelet_network, self.frame.points_to_local, route_end, corridor, extension,
            corridor_margin=s.sampling.lateral_range_m + vehicle.length + 5.0,
            resolution=s.collision.road_grid_resolution_m, margin=s.collision.road_margin_m,
            max_cells=s.collision.road_grid_max_cells)
        self._outline = footprint_outline(vehicle.length, vehicle.width, s.collision.footprint_point_spacing_m)
        self._edge_outline = footprint_outline(vehicle.length + 2 * ROAD_EDGE_M, vehicle.width + 2 * ROAD_EDGE_M,
                                               s.collision.footprint_point_spacing_m)
        self._core_reference = CoreReference(*self.frame.reference_tables())
        self._handlers: list[frenetix.TrajectoryHandler] = []
        self._dt: float | None = None
        self._approach: GoalApproach | None = None
        self._goal: Goal | None = None         # the goal's windows, time in seconds (steps of dt)
        # the manoeuvre chosen last: (absolute end time, end speed, lateral end offset)
        self._previous: tuple[float, float, float] | None = None
        self._previous_t: float | None = None
        self._last_plan: Trajectory | None = None
        self.last_cycle = PlanningCycle()

    # -- set-up of the core ------------------------------------------------------------------
    def _handler_for(self, dt: float, batch: int) -> frenetix.TrajectoryHandler:
        """The core's handler of the ``batch``-th batch of a cycle: one per batch, so that the
        samples of earlier batches stay valid until the next cycle."""
        if self._dt != dt:
            self._handlers, self._dt = [], dt
        while len(self._handlers) <= batch:
            self._handlers.append(self._new_handler(dt))
        return self._handlers[batch]

    def _new_handler(self, dt: float) -> frenetix.TrajectoryHandler:
        limits, wheelbase = self.vehicle.limits, self.vehicle.wheelbase
        whole = self.settings.check_whole_trajectory
        handler = frenetix.TrajectoryHandler(dt=dt)
        ff = feasibility_functions
        handler.add_feasability_function(ff.CheckYawRateConstraint(
            deltaMax=limits.max_steer, wheelbase=wheelbase, wholeTrajectory=whole))
        handler.add_feasability_function(ff.CheckAccelerationConstraint(
            switchingVelocity=limits.v_switch, maxAcceleration=limits.max_accel, wholeTrajectory=whole))
        handler.add_feasability_function(ff.CheckCurvatureConstraint(
            deltaMax=limits.max_steer, wheelbase=wheelbase, wholeTrajectory=whole))
        handler.add_feasability_function(ff.CheckCurvatureRateConstraint(
            wheelbase=wheelbase, velocityDeltaMax=limits.max_steer_rate, wholeTrajectory=whole))
        w = self.settings.costs
        cf = cost_functions
        for name, weight, cls in (("lateral_jerk", w.lateral_jerk, cf.CalculateLateralJerkCost),
                                  ("longitudinal_jerk", w.longitudinal_jerk, cf.CalculateLongitudinalJerkCost),
                                  ("distance_to_reference_path", w.distance_to_reference_path,
                                   cf.CalculateDistanceToReferencePathCost),
                                  ("orientation_offset", w.orientation_offset, cf.CalculateOrientationOffsetCost),
                                  ("acceleration", w.acceleration, cf.CalculateAccelerationCost)):
            if weight > 0:
                handler.add_cost_function(cls(name, weight))
        return handler

    def _approach_for(self, dt: float) -> GoalApproach:
        """The goal approach (its time window is in steps of ``dt``), built at the first cycle."""
        if self._approach is None or self._dt != dt:
            self._goal = Goal.of(self.goal, dt)
            self._approach = goal_approach(self.reference_path, self._goal, self.speed_profile,
                                           self.settings.speed.comfortable_deceleration, self.vehicle, self._network,
                                           self.vehicle.rear_axle_to_center)
        return self._approach

    def _goal_in_reach(self, observed: State, t: float, speed: float) -> bool:
        """Might a plan from ``observed`` at ``t`` reach a goal state within the horizon: its time
        window overlaps the horizon and its position lies within the distance driven at ``speed``
        (and a car's length) of the vehicle's centre?"""
        horizon = self.settings.sampling.horizon_s
        reach = speed * horizon + self.vehicle.length
        return any((gs.time is None or (gs.time.lo <= t + horizon and gs.time.hi >= t))
                   and gs.distance_from_position(observed.x, observed.y) <= reach
                   for gs in self._goal.states)

    # -- planning ----------------------------------------------------------------------------
    def plan(self, observed: State, t: float, world: World) -> Trajectory | None:
        cycle = PlanningCycle(t=t)
        self.last_cycle = cycle
        dt = float(world.dt)
        times = t + dt * np.arange(steps_in_horizon(self.settings.sampling, dt) + 1)
        clock = time.perf_counter()
        origin = self._on_last_plan(observed, t) or observed
        self._last_plan = None
        start = self._start(origin, t, dt, cycle)
        cycle.timings["projection"] += time.perf_counter() - clock
        if start is None:
            cycle.outcome = PlanOutcome.PROJECTION_FAILED
            return None
        traffic = predict_traffic(world.traffic, times, self.frame.xy_to_local, self.frame.rotation,
                                  self.settings.collision.traffic_margin_m)
        if self._previous_t is None or not (self._previous_t < t <= self._previous_t + 10 * dt):
            self._previous = None          # a new run, or a long gap: nothing to continue
        chosen = self._search(start, traffic, cycle)
        if chosen is None and cycle.feasible == cycle.rejected_infeasible and self.settings.relax_initial_state:
            # nothing feasible from the observed acceleration and steering (physics may hand us
            # values no polynomial can continue): retry from the observed pose and speed alone
            clock = time.perf_counter()
            start = self._relaxed(start)
            cycle.timings["projection"] += time.perf_counter() - clock
            if start is not None:
                cycle.relaxed = True
                chosen = self._search(start, traffic, cycle)
        self._previous_t = t
        if chosen is None:
            self._previous = None
            if not cycle.outcome:
                cycle.outcome = (PlanOutcome.NO_FEASIBLE_SAMPLE if cycle.feasible == cycle.rejected_infeasible
                                 else PlanOutcome.ALL_COLLIDING)
            return None
        p = chosen.parameters[0]
        self._previous = (t + float(p[END_TIME]), float(p[END_SPEED]), float(p[END_OFFSET]))
        clock = time.perf_counter()
        plan = self._to_trajectory(chosen, origin, times, dt)
        cycle.timings["conversion"] += time.perf_counter() - clock
        cycle.outcome = cycle.outcome or PlanOutcome.PLANNED
        self._last_plan = plan
        return plan

    def _on_last_plan(self, observed: State, t: float) -> State | None:
        """The last plan's state at ``t`` when the vehicle is close to it (`continue_plan_within_m`,
        `CONTINUE_PLAN_HEADING` and `CONTINUE_PLAN_SPEED`): the next plan starts there, so that the
        tracking error stays the controller's to correct instead of becoming the plan's. Replanned
        from where the vehicle is, a car that runs a centimetre wide each cycle drifts a little
        further every cycle and swings out of curves."""
        plan, within = self._last_plan, self.settings.continue_plan_within_m
        if plan is None or within is None or not plan.t[0] < t <= plan.t_end:
            return None
        on_plan = plan.at(t)
        if (math.hypot(observed.x - on_plan.x, observed.y - on_plan.y) > within
                or abs(wrap_angle(observed.yaw - on_plan.yaw)) > CONTINUE_PLAN_HEADING
                or abs(observed.v - on_plan.v) > CONTINUE_PLAN_SPEED):
            return None
        return on_plan

    @property
    def failure_reason(self) -> str:
        """Why the last cycle found no plan, in counts of rejected samples ("" after a plan)."""
        c = self.last_cycle
        if c.outcome in (None, PlanOutcome.PLANNED):
            return ""
        if c.outcome == PlanOutcome.PROJECTION_FAILED:
            return "the observed state cannot be projected onto the reference path"
        return (f"{c.outcome.replace('_', ' ')}: of {c.samples} samples {c.feasible} feasible; "
                f"rejected {c.rejected_traffic} for traffic, {c.rejected_road} for the road edge, "
                f"{c.rejected_infeasible} for the vehicle's limits")

    def _start(self, observed: State, t: float, dt: float, cycle: PlanningCycle) -> _Start | None:
        """The observed state projected into the Frenet frame, and the speed to aim at."""
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
        approach = self._approach_for(dt)
        aim = desired_speed(self.speed_profile, approach, s_ref, t, v, lookahead)
        desired = aim.speed
        cycle.desired_speed = desired
        may_overtake = approach.distance_to_goal(s_ref) > max(lookahead, NO_OVERTAKING_BEFORE_GOAL_M)
        speed = self.settings.speed
        bound = speed.late_lateral_acceleration if aim.late else speed.max_lateral_acceleration
        in_reach = self._goal_in_reach(observed, t, max(v, desired))
        return _Start(t, dt, x0_lon, x0_lat, float(x_rear), float(y_rear), yaw_local, v, desired, low_velocity,
                      may_overtake, bound, in_reach)

    def _relaxed(self, start: _Start) -> _Start | None:
        """``start`` with zero acceleration and the reference path's curvature."""
        _, kappa_ref, _ = self.frame.reference_at(np.array([start.x0_lon[0]]))
        steer_ref = math.atan(self.vehicle.wheelbase * float(kappa_ref[0]))
        try:
            x0_lon, x0_lat = self.frame.initial_state(start.x_rear, start.y_rear, start.yaw_local, start.v, 0.0,
                                                      steer_ref, self.vehicle.wheelbase, start.low_velocity)
        except (RuntimeError, ValueError):
            return None
        return replace(start, x0_lon=x0_lon, x0_lat=x0_lat)

    def _search(self, start: _Start, traffic: TrafficPrediction, cycle: PlanningCycle) -> CartesianBatch | None:
        """Sample, and return the cheapest plan that passes our checks, the core evaluating
        samples in its cost order as they are looked at."""
        order = self._cost_order(start, cycle)
        clock, evaluation = time.perf_counter(), cycle.timings["evaluation"]
        chosen = self._first_passing(order, start, traffic, cycle)
        cycle.timings["collision"] += time.perf_counter() - clock - (cycle.timings["evaluation"] - evaluation)
        cycle.feasible += order.feasible
        cycle.evaluated += order.evaluated
        cycle.floor_misses += order.floor_misses
        return chosen

    def _cost_order(self, start: _Start, cycle: PlanningCycle) -> CostOrder:
        """The cycle's samples (with the last manoeuvre continued), to be evaluated by the core in
        its cost order (`cost_order`)."""
        s, dt = self.settings, start.dt
        clock = time.perf_counter()
        speeds = end_speeds(s.sampling, start.v, start.desired, self.vehicle.limits.max_speed)
        matrix = sampling_matrix(start.x0_lon, start.x0_lat, end_times(s.sampling, dt), speeds,
                                 lateral_offsets(s.sampling))
        continued = self._continued_manoeuvre(start)
        if continued is not None:
            matrix = np.vstack([matrix, continued])
        cycle.samples += len(matrix)
        points = steps_in_horizon(s.sampling, dt) + 1
        floor = cost_floor(matrix, dt, points, start.low_velocity, start.desired, s.costs, self._core_reference)
        functions = [trajectory_functions.FillCoordinates(
            lowVelocityMode=start.low_velocity, initialOrientation=start.yaw_local, coordinateSystem=self.frame.core,
            horizon=steps_in_horizon(s.sampling, dt) * dt + TIME_NUDGE)]
        if s.costs.velocity_offset > 0:
            functions.append(cost_functions.CalculateVelocityOffsetCost(
                "velocity_offset", s.costs.velocity_offset, start.desired, dt, s.sampling.t_min_s, False, 2))
        _lap(cycle, "sampling", clock)
        batches = iter(range(len(matrix)))

        def evaluate(rows: np.ndarray) -> list[tuple[float, int, object]]:
            clock = time.perf_counter()
            handler = self._handler_for(dt, next(batches))
            handler.add_function(functions[0])
            for function in functions[1:]:
                handler.add_cost_function(function)
            handler.generate_trajectories(np.ascontiguousarray(matrix[rows]), start.low_velocity)
            if s.concurrent_evaluation:
                handler.evaluate_all_current_functions_concurrent(False)
            else:
                handler.evaluate_all_current_functions(False)
            feasible = []
            for sample in handler.get_sorted_trajectories():
                if not sample.feasible:
                    break
                feasible.append((sample.cost, int(rows[sample.uniqueId]), sample))
            _lap(cycle, "evaluation", clock)
            return feasible

        return CostOrder(floor, evaluate)

    def _continued_manoeuvre(self, start: _Start) -> np.ndarray | None:
        """The last cycle's manoeuvre, continued: from the state it predicted, the polynomials with
        the same end conditions are its remainder (so a plan once found stays available)."""
        if self._previous is None:
            return None
        t_end, v_end, d_end = self._previous
        remaining = t_end - start.t
        if not start.dt <= remaining <= self.settings.sampling.horizon_s + TIME_NUDGE:
            return None
        return sampling_matrix(start.x0_lon, start.x0_lat, np.array([remaining - TIME_NUDGE]),
                               np.array([v_end]), np.array([d_end]))

    def _leeway(self, start: _Start) -> _RoadLeeway:
        """The plans' leeway at the road's edge: none when the vehicle is safely on the road;
        ``recovery_s`` to get back when it is not, without going further out than it is now (a
        tracking error of centimetres at the edge is no licence to leave the road); anywhere
        when it is off the road already."""
        cx, cy = self.vehicle.centre_of(start.x_rear, start.y_rear, start.yaw_local)
        centre = (np.array([cx]), np.array([cy]), np.array([start.yaw_local]))
        band = next((b for b in RoadBand if footprints_on_road(self.drivable_area, self._outline, *centre, b)[0]),
                    None)
        if band is RoadBand.SAFE:
            return _RoadLeeway()
        return _RoadLeeway(self._recovery_steps(start.dt), band)

    def _recovery_steps(self, dt: float) -> int:
        return int(round(self.settings.collision.recovery_s / dt))

    def _first_passing(self, order: CostOrder, start: _Start, traffic: TrafficPrediction,
                       cycle: PlanningCycle) -> CartesianBatch | None:
        """In cost order, a few at a time: the first plan within the limits, clear of traffic and on
        the road (and within the lateral-acceleration bound if any is). When traffic holds the
        cheapest such plan well below the desired speed (``blocked_speed_share``), a faster one among
        the next `BLOCKED_SEARCH_SAMPLES` (a lane change, an overtaking) is taken instead. With the
        goal in reach (``start.goal_in_reach``) the cheapest passing plan that reaches the goal is
        taken, looked for among as many more (only those that reach it are checked). When every
        plan leaves the road from a vehicle at the road's edge (within `ROAD_EDGE_M`), they are
        checked again with the recovery time to get back onto the safe cells."""
        leeway = self._leeway(start)
        chosen: CartesianBatch | None = None
        blocked = False
        fallback: CartesianBatch | None = None
        checked: list[CartesianBatch] = []
        chunk, beyond_chosen = FIRST_CHUNK, 0
        while beyond_chosen < BLOCKED_SEARCH_SAMPLES:
            samples = order.take(chunk)
            if not samples:
                break
            chunk = min(chunk * 2, MAX_CHUNK)
            batch = self.frame.cartesian(samples, start.low_velocity, start.yaw_local)
            only_reaching = chosen is not None and not blocked      # only a plan that reaches the goal would do now
            if only_reaching:
                reaching = np.flatnonzero(self._reaches_goal(batch, np.arange(len(samples)), start))
                if not len(reaching):
                    beyond_chosen += len(samples)
                    continue
                batch = _rows(batch, reaching)
            checked.append(batch)
            passing, lateral_ok = self._verdicts(batch, traffic, leeway, start, cycle)
            within = passing & (lateral_ok | (not self.settings.speed.enforce_lateral_acceleration))
            cycle.rejected_lateral_acceleration += int((passing & ~within).sum())
            if fallback is None and (passing & ~within).any():
                fallback = _row(batch, int(np.flatnonzero(passing & ~within)[0]))
            if start.goal_in_reach and within.any():
                reaching = np.flatnonzero(within)
                if not only_reaching:
                    reaching = reaching[self._reaches_goal(batch, reaching, start)]
                if len(reaching):               # the cheapest plan that reaches the goal
                    return _row(batch, int(reaching[0]))
            for i in np.flatnonzero(within):
                if chosen is None:
                    chosen = _row(batch, i)
                    blocked = self._blocked(chosen, start, cycle)
                    if not (blocked or start.goal_in_reach):
                        return chosen
                elif blocked and batch.v[i, -1] >= chosen.v[0, -1] + BLOCKED_SPEED_GAIN * start.desired:
                    return _row(batch, i)
            if chosen is not None:
                beyond_chosen += len(samples)
        if chosen is None and fallback is None and leeway.steps == 0 and cycle.rejected_road \
                and self._at_road_edge(start):
            chosen = self._first_recovering(checked, start, traffic)
        if chosen is None and fallback is None and cycle.rejected_traffic:
            chosen = self._struck_from_behind(checked, start, traffic, leeway, cycle)
        return chosen or fallback

    def _struck_from_behind(self, checked: list[CartesianBatch], start: _Start, traffic: TrafficPrediction,
                            leeway: _RoadLeeway, cycle: PlanningCycle) -> CartesianBatch | None:
        """When every plan within the limits and on the road meets traffic: of the plans whose every
        encounter within the horizon is another road user running into the ego from behind
        (replayed traffic does not brake for it, and braking would only bring it sooner; what the
        stopping distance beyond the horizon would meet is not counted here), the one met latest
        (driving away from it; the cheapest of equals), ``cycle.outcome`` saying so; None when every
        plan runs into someone (the planner fails, and says so)."""
        veh = self.vehicle
        hl, hw = veh.length / 2, veh.width / 2
        no_traffic = TrafficPrediction(*(np.zeros((0, 1)),) * 3, np.zeros(0), np.zeros(0), np.zeros(0))
        best: tuple[float, CartesianBatch, int] | None = None
        for batch in checked:
            cx, cy = veh.centre_of(batch.x, batch.y, batch.yaw)
            overlaps = traffic_overlaps(cx, cy, batch.yaw, hl, hw, traffic)
            if overlaps is None:      # met only beyond the horizon (braking to a stop): nobody the ego hits
                at_fault = np.zeros(len(cx), dtype=bool)
                met_at = np.full(len(cx), np.inf)
            else:        # judged where each participant is met first (replayed, it drives on through the ego)
                met, struck = overlaps[:, 1:], struck_from_behind(cx, cy, batch.yaw, hl, traffic)[:, 1:]
                first = met.argmax(axis=1)                                  # (plans, participants)
                struck_first = np.take_along_axis(struck, first[:, None, :], axis=1)[:, 0, :]
                at_fault = (met.any(axis=1) & ~struck_first).any(axis=1)
                touched = met.any(axis=2)                                   # (plans, steps)
                met_at = np.where(touched.any(axis=1), touched.argmax(axis=1), np.inf)
            _, on_road, _ = self._check(batch, no_traffic, leeway, start.dt, start.lateral_bound)
            innocent = np.flatnonzero(self._feasible(batch) & on_road & ~at_fault)
            if len(innocent):
                i = int(innocent[np.argmax(met_at[innocent])])              # the first of the latest met
                if best is None or met_at[i] > best[0]:
                    best = (float(met_at[i]), batch, i)
                if math.isinf(best[0]):
                    break
        if best is None:
            return None
        cycle.outcome = PlanOutcome.STRUCK_FROM_BEHIND
        return _row(best[1], best[2])

    def _reaches_goal(self, batch: CartesianBatch, rows: np.ndarray, start: _Start) -> np.ndarray:
        """Per plan ``rows`` of ``batch``: does it reach the goal (every window of a goal state,
        judged at the vehicle's centre) at one of its states?"""
        yaw = batch.yaw[rows]
        x, y = self.frame.xy_to_world(*self.vehicle.centre_of(batch.x[rows], batch.y[rows], yaw))
        t = np.broadcast_to(start.t + start.dt * np.arange(yaw.shape[1]), yaw.shape)
        return self._goal.reached_at(t, x, y, yaw + self.frame.rotation, batch.v[rows]).any(axis=1)

    def _at_road_edge(self, start: _Start) -> bool:
        """The footprint grown by `ROAD_EDGE_M` on every side leaves the road."""
        cx0, cy0 = self.vehicle.centre_of(start.x_rear, start.y_rear, start.yaw_local)
        return not footprints_on_road(self.drivable_area, self._edge_outline, np.array([cx0]), np.array([cy0]),
                                      np.array([start.yaw_local]))[0]

    def _first_recovering(self, checked: list[CartesianBatch], start: _Start,
                          traffic: TrafficPrediction) -> CartesianBatch | None:
        """The cheapest of the ``checked`` plans that passes when it may leave the safe cells (not
        the road) for the recovery time (the rejections of this second look are not counted)."""
        leeway = _RoadLeeway(self._recovery_steps(start.dt), RoadBand.ROAD)
        for batch in checked:
            passing, _ = self._verdicts(batch, traffic, leeway, start, PlanningCycle())
            if passing.any():
                return _row(batch, int(np.flatnonzero(passing)[0]))
        return None

    def _blocked(self, plan: CartesianBatch, start: _Start, cycle: PlanningCycle) -> bool:
        """Traffic holds ``plan`` well below the desired speed."""
        return (start.may_overtake and cycle.rejected_traffic > 0
                and plan.v[0, -1] < self.settings.speed.blocked_speed_share * start.desired)

    def _verdicts(self, batch: CartesianBatch, traffic: TrafficPrediction, leeway: _RoadLeeway, start: _Start,
                  cycle: PlanningCycle) -> tuple[np.ndarray, np.ndarray]:
        """Per plan of ``batch``: passes the limit, traffic and road checks?; within the lateral-
        acceleration bound? Counts the rejections in ``cycle``."""
        feasible_ok = self._feasible(batch)
        hit, on_road, lateral_ok = self._check(batch, traffic, leeway, start.dt, start.lateral_bound)
        cycle.checked += len(feasible_ok)
        cycle.rejected_infeasible += int((~feasible_ok).sum())
        cycle.rejected_traffic += int((feasible_ok & hit).sum())
        cycle.rejected_road += int((feasible_ok & ~hit & ~on_road).sum())
        return feasible_ok & ~hit & on_road, lateral_ok

    def _feasible(self, batch: CartesianBatch) -> np.ndarray:
        """Acceleration and curvature within the vehicle's limits, from the exact values (the
        core's own checks see halved second derivatives, see `frenet_frame`)."""
        limits, wheelbase = self.vehicle.limits, self.vehicle.wheelbase
        v, a, kappa = batch.v[:, 1:], batch.a[:, 1:], batch.kappa[:, 1:]
        a_max = np.where(v > limits.v_switch, limits.max_accel * limits.v_switch / np.maximum(v, 1e-9),
                         limits.max_accel)
        tol = 1e-6
        ok_a = ((a <= a_max + tol) & (a >= -limits.max_accel - tol)).all(axis=1)
        ok_k = (np.abs(kappa) <= math.tan(limits.max_steer) / wheelbase + tol).all(axis=1)
        return ok_a & ok_k

    def _check(self, batch: CartesianBatch, traffic: TrafficPrediction, leeway: _RoadLeeway, dt: float,
               lateral_bound: float):
        """Per plan of ``batch``: hits traffic?, stays on the road?, within ``lateral_bound`` and the
        steering rate?"""
        veh, s = self.vehicle, self.settings
        hl, hw = veh.length / 2, veh.width / 2
        n = len(batch.x)
        cx, cy = veh.centre_of(batch.x, batch.y, batch.yaw)
        if traffic.empty:
            hit = np.zeros(n, dtype=bool)
        else:
            # the present (step 0) is not checked: what overlaps now cannot be planned away
            hit = traffic_collisions(cx, cy, batch.yaw, hl, hw, traffic)[:, 1:].any(axis=1)
            b = s.collision.stopping_deceleration
            if b is not None and not hit.all():
                # braking beyond the horizon along the path must stop clear of traffic braking
                # from where it is at the horizon's end
                v_end = np.maximum(batch.v[:, -1], 0.0)
                steps = int(math.ceil(float(v_end.max()) / b / dt))
                if steps > 0:
                    tau = dt * np.arange(1, steps + 1)
                    t_stop = (v_end / b)[:, None]
                    tt = np.minimum(tau[None, :], t_stop)
                    travel = v_end[:, None] * tt - 0.5 * b * tt**2
                    ex, ey, eyaw = self.frame.curvilinear_to_local(batch.s[:, -1:] + travel, batch.d[:, -1:])
                    ex, ey = veh.centre_of(ex, ey, eyaw)
                    last = traffic.braking_from_end(steps, dt, s.collision.traffic_deceleration)
                    hit |= traffic_collisions(ex, ey, eyaw, hl, hw, last).any(axis=1)
        # the road only for plans clear of traffic (the road test costs most: many points)
        on_road = np.ones(n, dtype=bool)
        safe_from = min(1 + leeway.steps, cx.shape[1])
        rows = np.flatnonzero(~hit)
        if safe_from < cx.shape[1] and len(rows):
            on_road[rows] = footprints_on_road(self.drivable_area, self._outline, cx[rows, safe_from:],
                                               cy[rows, safe_from:], batch.yaw[rows, safe_from:]).all(axis=1)
        rows = rows[on_road[rows]]
        if safe_from > 1 and leeway.band is not None and len(rows):
            on_road[rows] = footprints_on_road(self.drivable_area, self._outline, cx[rows, 1:safe_from],
                                               cy[rows, 1:safe_from], batch.yaw[rows, 1:safe_from],
                                               leeway.band).all(axis=1)
        a_lat = (batch.v[:, 1:] ** 2 * np.abs(batch.kappa[:, 1:])).max(axis=1)
        steer_rate = np.abs(np.diff(np.arctan(veh.wheelbase * batch.kappa), axis=1)).max(axis=1) / dt
        return hit, on_road, (a_lat <= lateral_bound) & (steer_rate <= veh.limits.max_steer_rate)

    def _to_trajectory(self, plan: CartesianBatch, observed: State, times: np.ndarray, dt: float) -> Trajectory:
        n = len(times)
        x, y = self.frame.xy_to_world(plan.x[0, :n], plan.y[0, :n])
        yaw_local = plan.yaw[0, :n]
        # continuous heading starting exactly at the observed one
        yaw = observed.yaw + np.concatenate([[0.0], np.cumsum(wrap_angle(np.diff(yaw_local)))])
        yaw = yaw + (wrap_angle(yaw_local[0] + self.frame.rotation - observed.yaw))
        cx, cy = self.vehicle.centre_of(x, y, yaw)
        kappa = plan.kappa[0, :n]
        v = np.maximum(plan.v[0, :n], 0.0)
        steer = np.arctan(self.vehicle.wheelbase * kappa)
        cx[0], cy[0], yaw[0], v[0] = observed.x, observed.y, observed.yaw, max(observed.v, 0.0)
        return Trajectory(dt, t=times, x=cx, y=cy, yaw=yaw, v=v, a=plan.a[0, :n], yaw_rate=v * kappa,
                          steer=steer)


def _row(batch: CartesianBatch, i: int) -> CartesianBatch:
    return CartesianBatch(*(getattr(batch, f)[i:i + 1] for f in CartesianBatch.__dataclass_fields__))


def _rows(batch: CartesianBatch, rows: np.ndarray) -> CartesianBatch:
    return CartesianBatch(*(getattr(batch, f)[rows] for f in CartesianBatch.__dataclass_fields__))


def _lap(cycle: PlanningCycle, phase: str, since: float) -> float:
    now = time.perf_counter()
    cycle.timings[phase] += now - since
    return now
