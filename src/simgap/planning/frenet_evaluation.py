"""Stages 2 and 3 of a cycle of the Frenet planner (`simgap.planning.frenet`): **sample** end time
x end speed x lateral offset, and the last cycle's manoeuvre continued (`sample`); **evaluate** them
on the frenetix core (coordinates, kinematic feasibility, costs), lazily in its cost order
(`CoreEvaluation.cost_order` → `CostOrder`)."""

from __future__ import annotations

import time

import frenetix
import frenetix.trajectory_functions as trajectory_functions
import frenetix.trajectory_functions.cost_functions as cost_functions
import frenetix.trajectory_functions.feasability_functions as feasibility_functions
import numpy as np

from simgap.planning.cost_order import CoreReference, CostOrder, cost_floor
from simgap.planning.frenet_cycle import Manoeuvre, PlanningCycle, Start, lap
from simgap.planning.frenet_frame import FrenetFrame
from simgap.planning.sampling import (
    TIME_NUDGE,
    end_speeds,
    end_times,
    lateral_offsets,
    sampling_matrix,
    steps_in_horizon,
)
from simgap.planning.settings import FrenetSettings, SamplingSettings


class CoreEvaluation:
    """A cycle's samples and the core that evaluates them, with its handlers (one per batch of a
    cycle, so that the samples of earlier batches stay valid until the next cycle; new ones when
    the time step changes)."""

    def __init__(self, vehicle, settings: FrenetSettings, frame: FrenetFrame, core_reference: CoreReference):
        self.vehicle, self.settings, self.frame, self.core_reference = vehicle, settings, frame, core_reference
        self._dt: float | None = None
        self._handlers: list[frenetix.TrajectoryHandler] = []

    def cost_order(self, start: Start, cycle: PlanningCycle, manoeuvre: Manoeuvre | None = None) -> CostOrder:
        """The cycle's samples (with ``manoeuvre`` continued), to be evaluated by the core in its
        cost order (`cost_order`): coordinates, the kinematic feasibility checks and the costs."""
        s, dt = self.settings, start.dt
        clock = time.perf_counter()
        matrix = sample(start, s.sampling, self.vehicle.limits.max_speed, manoeuvre)
        cycle.samples += len(matrix)
        points = steps_in_horizon(s.sampling, dt) + 1
        floor = cost_floor(matrix, dt, points, start.low_velocity, start.desired, s.costs, self.core_reference)
        functions = [trajectory_functions.FillCoordinates(
            lowVelocityMode=start.low_velocity, initialOrientation=start.yaw_local, coordinateSystem=self.frame.core,
            horizon=steps_in_horizon(s.sampling, dt) * dt + TIME_NUDGE)]
        if s.costs.velocity_offset > 0:
            functions.append(cost_functions.CalculateVelocityOffsetCost(
                "velocity_offset", s.costs.velocity_offset, start.desired, dt, s.sampling.t_min_s, False, 2))
        lap(cycle, "sampling", clock)
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
            lap(cycle, "evaluation", clock)
            return feasible

        return CostOrder(floor, evaluate)

    def _handler_for(self, dt: float, batch: int) -> frenetix.TrajectoryHandler:
        """The core's handler of the ``batch``-th batch of a cycle."""
        if self._dt != dt:                  # a new time step: new handlers
            self._dt, self._handlers = dt, []
        handlers = self._handlers
        while len(handlers) <= batch:
            handlers.append(_new_handler(dt, self.vehicle, self.settings))
        return handlers[batch]


def sample(start: Start, settings: SamplingSettings, max_speed: float, manoeuvre: Manoeuvre | None) -> np.ndarray:
    """The cycle's sampling matrix: end time x end speed x lateral offset from ``start``, and the
    last cycle's ``manoeuvre`` continued (`continued_manoeuvre`) as its last row."""
    speeds = end_speeds(settings, start.v, start.desired, max_speed)
    matrix = sampling_matrix(start.x0_lon, start.x0_lat, end_times(settings, start.dt), speeds,
                             lateral_offsets(settings))
    continued = continued_manoeuvre(start, manoeuvre, settings.horizon_s)
    if continued is not None:
        matrix = np.vstack([matrix, continued])
    return matrix


def continued_manoeuvre(start: Start, manoeuvre: Manoeuvre | None, horizon_s: float) -> np.ndarray | None:
    """The last cycle's manoeuvre, continued: from the state it predicted, the polynomials with
    the same end conditions are its remainder (so a plan once found stays available)."""
    if manoeuvre is None:
        return None
    remaining = manoeuvre.t_end - start.t
    if not start.dt <= remaining <= horizon_s + TIME_NUDGE:
        return None
    return sampling_matrix(start.x0_lon, start.x0_lat, np.array([remaining - TIME_NUDGE]),
                           np.array([manoeuvre.v_end]), np.array([manoeuvre.d_end]))


def _new_handler(dt: float, vehicle, settings: FrenetSettings) -> frenetix.TrajectoryHandler:
    """A core handler with the vehicle's kinematic feasibility checks and the cost functions of
    ``settings`` (those with a positive weight)."""
    limits, wheelbase = vehicle.limits, vehicle.wheelbase
    whole = settings.check_whole_trajectory
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
    w = settings.costs
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
