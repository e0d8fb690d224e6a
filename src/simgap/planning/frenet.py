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
  further out (`frenet_checks.RoadLeeway`); the desired speed leaves part of the steering rate unused
  (`STEER_RATE_SHARE`), and plans beyond the steering rate are a last resort.

A cycle is a sequence of stages, each with typed inputs and outputs:

1. **project** (`frenet_start.StartProjection`): the observed state into the Frenet frame, and the speed
   to aim at → `Start`;
2. **sample** (`frenet_evaluation.sample`): end time x end speed x lateral offset, and the last cycle's manoeuvre
   continued (`CycleMemory`) → the sampling matrix;
3. **evaluate** (`frenet_evaluation.CoreEvaluation`): the core's coordinates, kinematic feasibility and
   costs, lazily in its cost order → `CostOrder`;
4. **check** (`frenet_search.PlanSearch.check`): the vehicle's limits from exact values, traffic, the road
   and the lateral-acceleration bound (`frenet_checks`), chunk by chunk → `CheckedChunk`;
5. **choose** (`plan_choice.step` and `plan_choice.final`, pure): which checked sample wins →
   `Choice`; when none, a **second look** (`PlanSearch.second_look`) at the same samples
   from the road's edge or with traffic that runs into the ego from behind;
6. **convert** (`to_trajectory`): the chosen plan in simgap's convention → `Trajectory`.

What one cycle leaves the next is `CycleMemory` (the manoeuvre chosen, when, and the plan); the
cycle's typed values live in `frenet_cycle`.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace

import numpy as np

from simgap.planning.collision import DrivableAreaGrid, TrafficPrediction, predict_traffic
from simgap.planning.cost_order import CoreReference, CostOrder
from simgap.planning.frenet_checks import ROAD_EDGE_M, PlanChecks
from simgap.planning.frenet_cycle import PHASES, CycleMemory, Manoeuvre, PlanningCycle, Start
from simgap.planning.frenet_evaluation import CoreEvaluation, sample
from simgap.planning.frenet_frame import CartesianBatch, FrenetFrame
from simgap.planning.frenet_search import PlanSearch
from simgap.planning.frenet_start import StartProjection
from simgap.planning.plan_choice import BLOCKED_SEARCH_SAMPLES, BLOCKED_SPEED_GAIN
from simgap.planning.protocol import Planner, PlannerSetup, PlanOutcome, World
from simgap.planning.reference_path import ReferencePath, plan_reference_path
from simgap.planning.sampling import END_OFFSET, END_SPEED, END_TIME, steps_in_horizon
from simgap.planning.settings import FrenetSettings
from simgap.planning.speed_profile import GoalApproach, SpeedProfile, cruise_speed, goal_approach
from simgap.scenario.goal import Goal
from simgap.trajectory import State, Trajectory, wrap_angle

__all__ = ["BLOCKED_SEARCH_SAMPLES", "BLOCKED_SPEED_GAIN", "PHASES", "ROAD_EDGE_M", "CycleMemory", "FrenetPlanner",
           "FrenetSettings", "Manoeuvre", "PlanningCycle", "Start", "sample", "to_trajectory"]

# the desired speed asks for at most this share of the vehicle's steering rate where the curvature
# changes: a physical car needs the rest to correct its tracking errors
STEER_RATE_SHARE = 0.85
# the next plan continues the last one when the vehicle is this close to it (and within
# settings.continue_plan_within_m) [rad], [m/s]
CONTINUE_PLAN_HEADING, CONTINUE_PLAN_SPEED = 0.1, 1.0
# the last manoeuvre is continued when the last cycle was at most this many steps ago
CONTINUE_MANOEUVRE_STEPS = 10


@dataclass
class _StepSetUp:
    """What depends on the time step and is built at the first cycle: the goal's windows (time in
    seconds, steps of ``dt``) and the goal approach."""

    dt: float
    goal: Goal
    approach: GoalApproach


# -- stage 6: convert --------------------------------------------------------------------------
def to_trajectory(plan: CartesianBatch, observed: State, times: np.ndarray, dt: float, frame: FrenetFrame,
                  vehicle) -> Trajectory:
    """The single plan of ``plan`` (local frame, rear axle) as a `Trajectory` at ``times``
    (vehicle centre, world frame), starting exactly at ``observed``."""
    n = len(times)
    x, y = frame.xy_to_world(plan.x[0, :n], plan.y[0, :n])
    yaw_local = plan.yaw[0, :n]
    # continuous heading starting exactly at the observed one
    yaw = observed.yaw + np.concatenate([[0.0], np.cumsum(wrap_angle(np.diff(yaw_local)))])
    yaw = yaw + (wrap_angle(yaw_local[0] + frame.rotation - observed.yaw))
    cx, cy = vehicle.centre_of(x, y, yaw)
    kappa = plan.kappa[0, :n]
    v = np.maximum(plan.v[0, :n], 0.0)
    steer = np.arctan(vehicle.wheelbase * kappa)
    cx[0], cy[0], yaw[0], v[0] = observed.x, observed.y, observed.yaw, max(observed.v, 0.0)
    return Trajectory(dt, t=times, x=cx, y=cy, yaw=yaw, v=v, a=plan.a[0, :n], yaw_rate=v * kappa,
                      steer=steer)


def on_last_plan(plan: Trajectory | None, observed: State, t: float, within: float | None) -> State | None:
    """The last ``plan``'s state at ``t`` when the vehicle is close to it (``within`` [m],
    `CONTINUE_PLAN_HEADING` and `CONTINUE_PLAN_SPEED`): the next plan starts there, so that the
    tracking error stays the controller's to correct instead of becoming the plan's. Replanned
    from where the vehicle is, a car that runs a centimetre wide each cycle drifts a little
    further every cycle and swings out of curves."""
    if plan is None or within is None or not plan.t[0] < t <= plan.t_end:
        return None
    on_plan = plan.at(t)
    if (math.hypot(observed.x - on_plan.x, observed.y - on_plan.y) > within
            or abs(wrap_angle(observed.yaw - on_plan.yaw)) > CONTINUE_PLAN_HEADING
            or abs(observed.v - on_plan.v) > CONTINUE_PLAN_SPEED):
        return None
    return on_plan


class FrenetPlanner(Planner):
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
        self.checks = PlanChecks(vehicle, s, self.frame, self.drivable_area)
        self.search = PlanSearch(vehicle, s, self.frame, self.checks)
        self.projection = StartProjection(vehicle, s, self.frame, self.speed_profile)
        self._core_reference = CoreReference(*self.frame.reference_tables())
        self.evaluation = CoreEvaluation(vehicle, s, self.frame, self._core_reference)
        self._step_set_up: _StepSetUp | None = None
        self.memory = CycleMemory()
        self.last_cycle = PlanningCycle()

    def _set_up_for(self, dt: float) -> _StepSetUp:
        """The set-up for time step ``dt`` (built anew when it changes)."""
        if self._step_set_up is None or self._step_set_up.dt != dt:
            goal = Goal.of(self.goal, dt)
            approach = goal_approach(self.reference_path, goal, self.speed_profile,
                                     self.settings.speed.comfortable_deceleration, self.vehicle, self._network,
                                     self.vehicle.rear_axle_to_center)
            self._step_set_up = _StepSetUp(dt, goal, approach)
        return self._step_set_up

    def cost_order(self, start: Start, cycle: PlanningCycle, manoeuvre: Manoeuvre | None = None) -> CostOrder:
        """The cycle's samples (with ``manoeuvre`` continued), to be evaluated by the core in its
        cost order: `CoreEvaluation.cost_order`."""
        return self.evaluation.cost_order(start, cycle, manoeuvre)

    # -- the cycle ---------------------------------------------------------------------------
    def plan(self, observed: State, t: float, world: World) -> Trajectory | None:
        cycle = PlanningCycle(t=t)
        self.last_cycle = cycle
        dt = float(world.dt)
        times = t + dt * np.arange(steps_in_horizon(self.settings.sampling, dt) + 1)
        clock = time.perf_counter()
        memory = self.memory
        origin = on_last_plan(memory.last_plan, observed, t, self.settings.continue_plan_within_m) or observed
        memory = self.memory = replace(memory, last_plan=None)
        start = self.project(origin, t, dt, cycle)
        cycle.timings["projection"] += time.perf_counter() - clock
        if start is None:
            cycle.outcome = PlanOutcome.PROJECTION_FAILED
            return None
        traffic = predict_traffic(world.traffic, times, self.frame.xy_to_local, self.frame.rotation,
                                  self.settings.collision.traffic_margin_m)
        if memory.t is None or not (memory.t < t <= memory.t + CONTINUE_MANOEUVRE_STEPS * dt):
            memory = self.memory = replace(memory, manoeuvre=None)   # a new run, or a long gap: nothing to continue
        chosen = self._search(start, traffic, cycle, memory.manoeuvre)
        if chosen is None and cycle.feasible == cycle.rejected_infeasible and self.settings.relax_initial_state:
            # nothing feasible from the observed acceleration and steering (physics may hand us
            # values no polynomial can continue): retry from the observed pose and speed alone
            clock = time.perf_counter()
            start = self.projection.relaxed(start)
            cycle.timings["projection"] += time.perf_counter() - clock
            if start is not None:
                cycle.relaxed = True
                chosen = self._search(start, traffic, cycle, memory.manoeuvre)
        if chosen is None:
            self.memory = CycleMemory(None, t, None)
            if not cycle.outcome:
                cycle.outcome = (PlanOutcome.NO_FEASIBLE_SAMPLE if cycle.feasible == cycle.rejected_infeasible
                                 else PlanOutcome.ALL_COLLIDING)
            return None
        p = chosen.parameters[0]
        self.memory = CycleMemory(Manoeuvre(t + float(p[END_TIME]), float(p[END_SPEED]), float(p[END_OFFSET])), t)
        clock = time.perf_counter()
        plan = to_trajectory(chosen, origin, times, dt, self.frame, self.vehicle)
        cycle.timings["conversion"] += time.perf_counter() - clock
        cycle.outcome = cycle.outcome or PlanOutcome.PLANNED
        self.memory = replace(self.memory, last_plan=plan)
        return plan

    @property
    def failure_reason(self) -> str:    # type: ignore[override]  # read-only: derived from the last cycle
        """Why the last cycle found no plan, in counts of rejected samples ("" after a plan)."""
        c = self.last_cycle
        if c.outcome in (None, PlanOutcome.PLANNED):
            return ""
        if c.outcome == PlanOutcome.PROJECTION_FAILED:
            return "the observed state cannot be projected onto the reference path"
        return (f"{c.outcome.replace('_', ' ')}: of {c.samples} samples {c.feasible} feasible; "
                f"rejected {c.rejected_traffic} for traffic, {c.rejected_road} for the road edge, "
                f"{c.rejected_infeasible} for the vehicle's limits")

    # -- stage 1: project ----------------------------------------------------------------------
    def project(self, observed: State, t: float, dt: float, cycle: PlanningCycle) -> Start | None:
        """The observed state projected into the Frenet frame, and the speed to aim at (None: it
        cannot be projected): `StartProjection.project`."""
        set_up = self._set_up_for(dt)
        return self.projection.project(observed, t, dt, cycle, set_up.approach, set_up.goal)

    def _search(self, start: Start, traffic: TrafficPrediction, cycle: PlanningCycle,
                manoeuvre: Manoeuvre | None) -> CartesianBatch | None:
        """Sample, and return the chosen plan, the core evaluating samples in its cost order as
        they are looked at."""
        order = self.cost_order(start, cycle, manoeuvre)
        clock, evaluation = time.perf_counter(), cycle.timings["evaluation"]
        chosen = self.search.choose(order, start, traffic, cycle, self._set_up_for(start.dt).goal)
        cycle.timings["collision"] += time.perf_counter() - clock - (cycle.timings["evaluation"] - evaluation)
        cycle.feasible += order.feasible
        cycle.evaluated += order.evaluated
        cycle.floor_misses += order.floor_misses
        return chosen
