"""What every trajectory-tracking controller shares: its own update rate, the speed controller,
the steering feed-forward from the plan's curvature, and the steering-angle limit.

A concrete controller only says how it turns the plan and the measured pose into a steering
angle (`TrackingController._steer`). Shared here as well: a slow integral of the centre's
lateral error (`TrackingController.lateral_integral`), which removes the steady offset that
tyre slip leaves behind when the plan (kinematic) and the vehicle (dynamic) disagree, and the
longitudinal side — speed and along-track errors measured on the plan's centre path at time
``t``, handed to `simgap.control.longitudinal.SpeedController`.
"""

from __future__ import annotations

import math

from pydantic import BaseModel, ConfigDict, Field

from simgap.control.longitudinal import LongitudinalMap, SpeedController, SpeedGains
from simgap.control.planned_path import PlannedPath, Projection
from simgap.control.protocol import Command
from simgap.trajectory import State, Trajectory
from simgap.vehicles.physics import VehiclePhysics

MIN_RATE_HZ = 50.0
CONTROLLER_HZ = 100.0    # the controllers' rate unless told otherwise
_STOP_LOOKAHEAD = 0.5    # s of plan checked for a planned standstill


class TrackingGains(BaseModel):
    """Gains every tracking controller has."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    curvature_feedforward: float = Field(
        1.0, ge=0, le=1.5,
        description="weight of the steering feed-forward from the plan's curvature [-]")
    understeer_gradient: float | None = Field(
        None, description="extra steering per lateral acceleration, K_us in "
        "delta = atan(L kappa) + K_us v^2 kappa [rad s^2/m]; default: the linear-range value of "
        "the vehicle's tyres at its axle loads (0 for a vehicle without physics)")
    sideslip_compensation: float = Field(
        1.0, ge=0, le=1.5, description="weight of the steady-sideslip compensation: heading feedback "
        "compares against the plan's heading turned in by the sideslip a real car runs with in a "
        "steady turn (from the vehicle's tyres); 0: against the kinematic heading [-]")
    lateral_integral_gain: float = Field(
        2.0, ge=0, description="integral of the centre's lateral error, as lateral "
        "acceleration [1/s^3]: the steering term grows at gain * L / v^2 * error [rad/s]; it "
        "removes the steady offset left by tyre slip the plan does not know of")
    lateral_integral_limit: float = Field(
        0.05, ge=0, description="bound on the integral steering term [rad]")
    lateral_integral_min_speed: float = Field(
        3.0, ge=0, description="the integral only runs above this speed [m/s]")
    speed: SpeedGains = Field(default_factory=SpeedGains, description="speed controller")


class TrackingController:
    """Base of the tracking controllers. Subclasses set ``name`` and implement `_steer`.

    ``command`` computes a new command when at least one period (1 / ``rate_hz``) has passed
    since the last update and otherwise returns the held one, so a backend may call it at
    any rate at or above ``rate_hz``.
    """

    name = "tracking"
    reference_offset = 0.0   # where the tracked reference point sits, ahead of the centre [m]

    def __init__(self, vehicle, gains: TrackingGains, rate_hz: float = CONTROLLER_HZ):
        if not rate_hz >= MIN_RATE_HZ:
            raise ValueError(f"rate_hz must be >= {MIN_RATE_HZ}, got {rate_hz}")
        self.vehicle = vehicle
        self.gains = gains
        self.rate_hz = float(rate_hz)
        self.period = 1.0 / self.rate_hz
        self.wheelbase = float(vehicle.wheelbase)
        self.rear_axle_to_center = float(vehicle.rear_axle_to_center)
        self.front_axle_to_center = float(vehicle.wheelbase - vehicle.rear_axle_to_center)
        self.max_steer = float(vehicle.limits.max_steer)
        self.pedal_map = LongitudinalMap.for_vehicle(vehicle)
        physics = vehicle.physics if isinstance(vehicle.physics, VehiclePhysics) else None
        self.understeer_gradient: float = (
            gains.understeer_gradient if gains.understeer_gradient is not None
            else physics.understeer_gradient(vehicle.wheelbase, vehicle.rear_axle_to_center) if physics is not None
            else 0.0)
        # heading of a real car in a steady turn minus the kinematic model's, per v^2 kappa: its
        # tyres slip, so it runs with less sideslip (beta_kin - beta = m a v^2 kappa / (L C_r))
        self._sideslip_gain = 0.0
        if physics is not None:
            _, c_rear = physics.axle_cornering_stiffness(vehicle.wheelbase, vehicle.rear_axle_to_center)
            self._sideslip_gain = physics.mass * self.front_axle_to_center / (vehicle.wheelbase * c_rear)
        self.speed = SpeedController(gains.speed, self.pedal_map, vehicle.limits.max_accel)
        self._path: PlannedPath | None = None
        self._path_plan: Trajectory | None = None
        self._last: Command | None = None
        self._t_last: float | None = None
        self._lateral_integral = 0.0
        self._centre_lateral = 0.0
        self._centre: PlannedPath | None = None
        #: quantities of the last update, for logging and tests
        self.diagnostics: dict[str, float] = {}

    # --- the Controller protocol ----------------------------------------------------------
    def reset(self, state: State) -> None:
        self.speed.reset()
        self._lateral_integral = 0.0
        self._centre_lateral = 0.0
        self._centre = None
        self._path = None
        self._path_plan = None
        self._last = None
        self._t_last = None
        self.diagnostics = {}
        self._reset_lateral(state)

    def command(self, measured: State, plan: Trajectory, t: float) -> Command:
        if self._last is not None and self._t_last is not None:
            if t < self._t_last + self.period * (1.0 - 1e-6):
                return self._last
        dt = self.period
        if self._t_last is not None and 0.0 < t - self._t_last < 10.0 * self.period:
            dt = t - self._t_last
        path = self._planned_path(plan)
        centre_path = self._centre_path(plan)
        v = max(measured.v, 0.0)
        centre = centre_path.project(measured.x, measured.y)
        self._centre_lateral = centre.lateral

        steer, proj = self._steer(measured, path, t, dt)
        steer = min(max(steer, -self.max_steer), self.max_steer)

        idx_t = centre_path.index_at_time(t)
        v_ref = max(centre_path.value("v", idx_t), 0.0)
        a_ref = centre_path.value("a", idx_t) if t <= plan.t_end else 0.0
        s_ref = centre_path.s_at_index(idx_t)
        if t > plan.t_end:
            s_ref += v_ref * (t - plan.t_end)
        along = s_ref - centre.s
        stop_planned = v_ref < self.gains.speed.standstill_speed and max(
            path.value("v", path.index_at_time(t + _STOP_LOOKAHEAD)),
            path.value("v", path.index_at_time(t + 0.5 * _STOP_LOOKAHEAD)),
        ) < self.gains.speed.standstill_speed
        throttle, brake = self.speed.pedals(v, measured.a, v_ref, a_ref, along, dt,
                                            stop_planned=stop_planned)
        cmd = Command(steer=float(steer), throttle=float(throttle), brake=float(brake))
        self.diagnostics.update(
            lateral_error=centre.lateral, tracked_point_lateral_error=proj.lateral, along_track_error=along, v_ref=v_ref, a_ref=a_ref,
            accel_demand=self.speed.last_demand)
        self._last = cmd
        self._t_last = t
        return cmd

    # --- for subclasses -------------------------------------------------------------------
    def _reset_lateral(self, state: State) -> None:
        """Reset the steering controller's memory."""

    def _steer(self, measured: State, path: PlannedPath, t: float, dt: float
               ) -> tuple[float, Projection]:
        """Road-wheel steering angle [rad] and the projection of the tracked point."""
        raise NotImplementedError

    def lateral_integral(self, v: float, dt: float) -> float:
        """Integral steering term [rad]. It integrates ``-gain * L / v^2 * e`` with ``e`` the
        lateral error of the vehicle's centre (the point every `State` describes), only while
        moving: a lateral-acceleration integral turned into steering, so that its effect on the
        lateral loop does not grow with speed."""
        lateral_error = self._centre_lateral
        g = self.gains
        if g.lateral_integral_gain > 0.0 and v > g.lateral_integral_min_speed:
            lim = g.lateral_integral_limit
            rate = g.lateral_integral_gain * self.wheelbase / (v * v)
            value = self._lateral_integral - rate * lateral_error * dt
            self._lateral_integral = min(max(value, -lim), lim)
        return self._lateral_integral

    def reference_point(self, state: State) -> tuple[float, float]:
        c, s = math.cos(state.yaw), math.sin(state.yaw)
        return state.x + self.reference_offset * c, state.y + self.reference_offset * s

    def steady_heading_offset(self, curvature: float, v: float) -> float:
        """How far a real car's heading turns inside the plan's (kinematic) heading in a steady
        turn of ``curvature`` at speed ``v`` [rad]: controllers that feed back heading compare
        against the plan's heading plus this, so they do not fight the car's natural sideslip."""
        return self.gains.sideslip_compensation * self._sideslip_gain * v * v * curvature

    def feedforward_steer(self, curvature: float, v: float) -> float:
        """Steering angle that holds ``curvature`` at speed ``v`` (kinematic + understeer)."""
        return (math.atan(self.wheelbase * curvature)
                + self.understeer_gradient * v * v * curvature)

    def _planned_path(self, plan: Trajectory) -> PlannedPath:
        if self._path is None or self._path_plan is not plan:
            self._path = PlannedPath(plan, self.reference_offset, wheelbase=self.wheelbase,
                                     rear_axle_to_center=self.rear_axle_to_center)
            self._path_plan = plan
        return self._path

    def _centre_path(self, plan: Trajectory) -> PlannedPath:
        if self.reference_offset == 0.0:
            return self._planned_path(plan)
        if self._centre is None or self._centre.plan is not plan:
            self._centre = PlannedPath(plan, 0.0, wheelbase=self.wheelbase,
                                       rear_axle_to_center=self.rear_axle_to_center)
        return self._centre
