"""A single-track vehicle that takes a `Command`: the plant of the mid-fidelity ``dynamic`` world.

The vehicle dynamics are CommonRoad's single-track model (``vehicle_dynamics_st`` of
commonroad-vehicle-models: linear tyres with load transfer, kinematic below 0.1 m/s), with a
CommonRoad parameter set (2 = BMW 320i). In front of it sit two actuators:

* steering: a first-order servo towards the commanded road-wheel angle,
  ``steer_rate = (target - steer) / steer_time_constant``, which the model then limits to the
  vehicle's steering-rate and angle limits;
* powertrain and brakes: throttle and brake become a longitudinal acceleration through
  `simgap.control.longitudinal.LongitudinalMap.acceleration` (the inverse of the controllers'
  pedal map, from the same ``physics`` numbers), delayed by a first-order lag
  ``accel_time_constant``, then limited by the model (power limit above ``v_switch``). Brakes
  and resistance stop the vehicle but never drive it backwards.

Integration: classical Runge-Kutta (RK4) with the inputs held over each sub-step of at most
``integration_step`` seconds (1 ms by default).

On a road with a relief the world hands the plant the slope under the car (`Slope`: gravity's
components along the road's tangent plane, along the car's heading and to its left), held over a
controller period: a body force, added to the model's longitudinal acceleration and, above walking
pace, turning its course (the side slip's rate). A braked car at a standstill holds while its
brakes hold more than the slope pulls; one that stands uphill cannot roll back (the plant's speed
is never negative). The load the slope takes off the tyres (``cos`` of its angle) is left out.

Road friction (a reality knob, 1.0 = the parameter set's dry road) scales the tyres' friction
coefficient. The single-track model's tyres are linear, so on their own they never run out of
grip; the plant therefore also caps the longitudinal acceleration by the friction circle,
``|a| <= sqrt((mu g)^2 - (v yaw_rate)^2)``, so that braking and driving on a slippery road take
what the road can give. `MultiBodyPlant` is the multi-body (MB) model instead: 29 states,
Pacejka tyres that saturate, suspension and wheel spin — about ten times slower.

The vehicle's geometry (axle positions), steering and acceleration limits and, when its
``physics`` gives one, its mass override the parameter set; the yaw inertia is scaled with
mass and wheelbase squared. Tyres and the centre-of-gravity height stay those of the set.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass
from functools import cache

from vehiclemodels.init_mb import init_mb
from vehiclemodels.utils.acceleration_constraints import acceleration_constraints
from vehiclemodels.vehicle_dynamics_mb import vehicle_dynamics_mb
from vehiclemodels.vehicle_dynamics_st import vehicle_dynamics_st
from vehiclemodels.vehicle_parameters import VehicleParameters, setup_vehicle_parameters

from simgap.control.longitudinal import LongitudinalMap
from simgap.control.protocol import Command
from simgap.errors import InputError
from simgap.sim.dynamic.settings import VEHICLE_MODELS
from simgap.sim.settings import DRY_ROAD_FRICTION
from simgap.trajectory import State, wrap_angle
from simgap.vehicles.constants import GRAVITY

PARAMETER_SETS = (1, 2, 3)


@dataclass(frozen=True)
class Slope:
    """Gravity's pull along a road's tangent plane at a car [m/s^2]: along its heading and to its left."""

    along: float
    across: float


@cache
def _parameter_set(params_id: int) -> VehicleParameters:
    return setup_vehicle_parameters(vehicle_id=params_id)


def single_track_parameters(vehicle, params_id: int = 2) -> VehicleParameters:
    """CommonRoad parameter set ``params_id`` adapted to ``vehicle`` (see the module doc)."""
    if params_id not in PARAMETER_SETS:
        raise InputError(f"unknown CommonRoad parameter set {params_id}", field="params_id",
                         allowed=", ".join(map(str, PARAMETER_SETS)))
    base = _parameter_set(params_id)
    p = copy.deepcopy(base)
    p.a = float(vehicle.front_axle_to_center)
    p.b = float(vehicle.rear_axle_to_center)
    lim = vehicle.limits
    p.steering.max, p.steering.min = float(lim.max_steer), -float(lim.max_steer)
    p.steering.v_max, p.steering.v_min = float(lim.max_steer_rate), -float(lim.max_steer_rate)
    p.longitudinal.a_max = float(lim.max_accel)
    p.longitudinal.v_max = float(lim.max_speed)
    p.longitudinal.v_switch = float(lim.v_switch)
    physics = vehicle.physics
    mass = physics.get("mass") if isinstance(physics, dict) else getattr(physics, "mass", None)
    if mass is not None:
        p.m = float(mass)
    p.I_z = base.I_z * (p.m / base.m) * ((p.a + p.b) / (base.a + base.b)) ** 2
    if getattr(physics, "inertia_yaw", None) is not None:
        p.I_z = float(physics.inertia_yaw)
    return p


# CommonRoad's single-track model is kinematic below 0.1 m/s and has slip dynamics above, whose
# rates grow as 1/v: RK4 stays stable with a sub-step up to about this many seconds per m/s of
# speed (measured: 1 ms at 0.11 m/s, 2 ms at 0.2, 8 ms at 0.5; 4 ms at 0.2 m/s spun the car at
# 2000 rad/s), so at walking pace the sub-step shrinks below integration_step
STABLE_STEP_PER_SPEED = 0.008
KINEMATIC_BELOW_M_S = 0.1
STANDSTILL_M_S = 1e-3           # the pedal map's standstill: below it brakes hold rather than decelerate


class SingleTrackPlant:
    """One vehicle on CommonRoad's single-track model, driven by steering/throttle/brake."""

    def __init__(self, vehicle, params_id: int = 2, *, integration_step: float = 1e-3,
                 steer_time_constant: float = 0.05, accel_time_constant: float = 0.1,
                 road_friction: float = DRY_ROAD_FRICTION):
        self.vehicle = vehicle
        self.params_id = params_id
        self.p = single_track_parameters(vehicle, params_id)
        self.road_friction = float(road_friction)
        self.p.tire.p_dy1 *= self.road_friction
        self.p.tire.p_dx1 *= self.road_friction
        self.grip = self.p.tire.p_dy1 * GRAVITY          # the friction circle's radius [m/s^2]
        self.pedal_map = LongitudinalMap.for_vehicle(vehicle)
        self.integration_step = float(integration_step)
        self.steer_time_constant = float(steer_time_constant)
        self.accel_time_constant = float(accel_time_constant)
        self.slope: Slope | None = None     # the road's slope under the car (None: flat)
        self._x: list[float] = [0.0] * 7
        self._t = 0.0
        self._accel = 0.0        # acceleration delivered by the powertrain/brake lag
        self._applied = 0.0      # acceleration applied to the model in the last sub-step
        self.state: State | None = None

    # ------------------------------------------------------------------------------------
    def reset(self, state: State) -> State:
        """Place the vehicle at ``state`` (slip angle: the kinematic one for its steering)."""
        lwb = self.p.a + self.p.b
        beta = math.atan(math.tan(state.steer) * self.p.b / lwb)
        v = max(state.v, 0.0)
        self._x = [state.x, state.y, state.steer, v, state.yaw, state.yaw_rate, beta]
        self._t = float(state.t)
        self._accel = float(state.a)
        self._applied = float(state.a)
        self.state = self._observe()
        return self.state

    def step(self, command: Command, dt: float) -> State:
        """Hold ``command`` for ``dt`` seconds and return the state afterwards."""
        if self.state is None:
            raise RuntimeError("reset the plant before stepping it")
        n = max(1, math.ceil(dt / self.integration_step - 1e-9))
        h = dt / n
        target = min(max(command.steer, self.p.steering.min), self.p.steering.max)
        lag = self._lag(h)
        x = self._x
        for _ in range(n):
            if x[3] < KINEMATIC_BELOW_M_S or x[3] * STABLE_STEP_PER_SPEED >= h:
                x = self._advance(x, command, target, h, *lag)
            else:            # walking pace: the slip dynamics are stiff, the sub-step shrinks with the speed
                m = math.ceil(h / (STABLE_STEP_PER_SPEED * x[3]))
                short = self._lag(h / m)
                for _ in range(m):
                    x = self._advance(x, command, target, h / m, *short)
        self._x = x
        self._t += dt
        self.state = self._observe()
        if not all(math.isfinite(c) for c in x):
            raise FloatingPointError(f"single-track plant diverged at t={self._t:.3f}: {x}")
        return self.state

    def _lag(self, h: float) -> tuple[float, float]:
        """The powertrain's first-order lag over a sub-step of ``h`` seconds, exact: the share of
        the old acceleration left at its end and the weight of the old one in its mean."""
        tau = self.accel_time_constant
        if tau <= 0:
            return 0.0, 0.0
        decay = math.exp(-h / tau)
        return decay, tau / h * (1.0 - decay)

    def _advance(self, x: list[float], command: Command, target: float, h: float,
                 decay: float, mean_weight: float) -> list[float]:
        """One sub-step: the pedals through the lag and the model's limits, then RK4."""
        v = x[3]
        demanded = self.pedal_map.acceleration(command.throttle, command.brake, v)
        a = demanded + (self._accel - demanded) * mean_weight
        self._accel = demanded + (self._accel - demanded) * decay
        pull = 0.0 if self.slope is None else self.slope.along
        if v <= 0.0 and a < 0.0:
            a = 0.0                      # brakes hold, they do not reverse
        elif v > 0.0 and v + (a + pull) * h < 0.0:
            a = -v / h - pull            # come to rest exactly at the end of the sub-step
        a = acceleration_constraints(v, a, self.p.longitudinal)
        lateral = v * x[5]
        cap = math.sqrt(max(self.grip * self.grip - lateral * lateral, 0.0))
        a = min(max(a, -cap), cap)
        slope = self.slope
        if slope is not None and v < STANDSTILL_M_S:
            slope, a = self._standing(slope, command, a, v, h)
        x = self._rk4(x, target, a, h, slope)
        if x[3] < 0.0:
            x[3] = 0.0
        self._applied = a if slope is None else a + slope.along
        return x

    def _standing(self, slope: Slope, command: Command, a: float, v: float, h: float) -> tuple[Slope | None, float]:
        """The slope's pull and the acceleration of a car at a standstill: the brakes (their
        deceleration in motion) hold a pull forward up to their own, a pull back holds the car
        unless the drive beats it (it cannot roll back); a car held stays where it is."""
        held = max(-self.pedal_map.acceleration(command.throttle, command.brake, 1.0), 0.0)
        if slope.along > 0.0:
            slope = Slope(slope.along - held, slope.across)
        if a + slope.along <= 0.0:
            return None, -v / h
        return slope, a

    # ------------------------------------------------------------------------------------
    def _rhs(self, x: list[float], target: float, a: float, slope: Slope | None) -> list[float]:
        steer_rate = ((target - x[2]) / self.steer_time_constant
                      if self.steer_time_constant > 0 else 0.0)
        rates = vehicle_dynamics_st(x, [steer_rate, a], self.p)
        if slope is not None:
            rates[3] += slope.along
            if x[3] >= KINEMATIC_BELOW_M_S:
                rates[6] += slope.across / x[3]         # a pull to the left turns the course left
        return rates

    def _rk4(self, x: list[float], target: float, a: float, h: float, slope: Slope | None) -> list[float]:
        if self.steer_time_constant <= 0:
            x = list(x)
            x[2] = target
        k1 = self._rhs(x, target, a, slope)
        x2 = [xi + 0.5 * h * ki for xi, ki in zip(x, k1)]
        k2 = self._rhs(x2, target, a, slope)
        x3 = [xi + 0.5 * h * ki for xi, ki in zip(x, k2)]
        k3 = self._rhs(x3, target, a, slope)
        x4 = [xi + h * ki for xi, ki in zip(x, k3)]
        k4 = self._rhs(x4, target, a, slope)
        return [xi + h / 6.0 * (a1 + 2.0 * a2 + 2.0 * a3 + a4)
                for xi, a1, a2, a3, a4 in zip(x, k1, k2, k3, k4)]

    def _observe(self) -> State:
        x = self._x
        return State(t=self._t, x=x[0], y=x[1], yaw=wrap_angle(x[4]), v=x[3], a=self._applied,
                     yaw_rate=x[5], steer=x[2])


class MultiBodyPlant(SingleTrackPlant):
    """The same actuators in front of CommonRoad's multi-body model (``vehicle_dynamics_mb``).

    Its reference point is the sprung mass's centre of gravity, taken as the vehicle's centre;
    speed is the magnitude of the longitudinal and lateral velocity there. The friction circle
    cap of the single-track plant is kept (the MB tyres saturate on their own as well).
    """

    def reset(self, state: State) -> State:
        lwb = self.p.a + self.p.b
        beta = math.atan(math.tan(state.steer) * self.p.b / lwb)
        v = max(state.v, 0.0)
        self._x = list(init_mb([state.x, state.y, state.steer, v, state.yaw, state.yaw_rate, beta], self.p))
        self._t = float(state.t)
        self._accel = float(state.a)
        self._applied = float(state.a)
        self.state = self._observe()
        return self.state

    def _rhs(self, x: list[float], target: float, a: float, slope: Slope | None) -> list[float]:
        steer_rate = ((target - x[2]) / self.steer_time_constant
                      if self.steer_time_constant > 0 else 0.0)
        rates = vehicle_dynamics_mb(x, [steer_rate, a], self.p)
        if slope is not None:            # body-frame velocities: longitudinal x[3], lateral x[10]
            rates[3] += slope.along
            rates[10] += slope.across
        return rates

    def _observe(self) -> State:
        x = self._x
        return State(t=self._t, x=x[0], y=x[1], yaw=wrap_angle(x[4]), v=math.hypot(x[3], x[10]),
                     a=self._applied, yaw_rate=x[5], steer=x[2])


PLANTS = dict(zip(VEHICLE_MODELS, (SingleTrackPlant, MultiBodyPlant)))    # by DynamicSettings.model
