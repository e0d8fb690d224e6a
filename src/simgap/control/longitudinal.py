"""Longitudinal control: an acceleration demand from the plan, and the pedal map that realises it.

Two pieces live here, and nowhere else:

* `LongitudinalMap` — the one place where an acceleration [m/s^2] becomes pedal positions
  (throttle, brake in [0, 1]) and back. It reads the vehicle's ``physics`` section:

  =========================  ======  ===============================================
  key                        unit    meaning
  =========================  ======  ===============================================
  ``mass``                   kg      total vehicle mass
  ``wheel_radius``           m       rolling radius of the wheels
  ``max_drive_torque``       N m     drive torque at full throttle, summed over the driven wheels
  ``max_brake_torque``       N m     brake torque at full brake, summed over all wheels
  ``drag_coefficient_area``  m^2     Cd * A (optional, default 0.64)
  ``rolling_resistance``     \\-      rolling-resistance coefficient (optional, default 0.012)
  =========================  ======  ===============================================

  A vehicle without a ``physics`` section gets BMW 320i-like defaults (`DEFAULT_PHYSICS`,
  mass from CommonRoad's parameter set 2). Physics backends use the inverse direction
  (`LongitudinalMap.acceleration`) when they model the powertrain as this same map.

* `SpeedController` — acceleration demand = plan acceleration (feed-forward) + PI(D) on the
  speed error (+ optionally a term on the along-track position error), limited, then mapped
  to pedals. It holds the vehicle with the brake at standstill and never asks for reverse.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from pydantic import BaseModel, ConfigDict, Field

from simgap.errors import InputError
from simgap.vehicles.constants import AIR_DENSITY, GRAVITY

#: Physics keys this module reads, with the values used when a vehicle has no ``physics``.
#: BMW 320i-like: mass of CommonRoad parameter set 2; 200 N m engine torque through a
#: 4.11 first gear and a 3.23 final drive at 90 % efficiency (~2400 N m at the wheels);
#: brakes that reach CommonRoad's a_max = 11.5 m/s^2 (1093 kg * 11.5 * 0.31 m ~ 3900 N m);
#: Cd 0.29 * frontal area 2.2 m^2.
DEFAULT_PHYSICS: dict[str, float] = {
    "mass": 1093.3,
    "wheel_radius": 0.31,
    "max_drive_torque": 2400.0,
    "max_brake_torque": 3900.0,
    "drag_coefficient_area": 0.64,
    "rolling_resistance": 0.012,
}
REQUIRED_PHYSICS_KEYS = ("mass", "wheel_radius", "max_drive_torque", "max_brake_torque")
OPTIONAL_PHYSICS_KEYS = ("drag_coefficient_area", "rolling_resistance")


@dataclass(frozen=True)
class LongitudinalMap:
    """Acceleration <-> pedal positions for one vehicle, on flat ground.

    ``F_drive = throttle * max_drive_torque / wheel_radius``,
    ``F_brake = brake * max_brake_torque / wheel_radius`` (opposes motion),
    ``F_resist = rolling_resistance * mass * g + 0.5 * rho * drag_coefficient_area * v^2``
    (opposes motion; only when moving),
    ``a = (F_drive - F_brake - F_resist) / mass``.
    """

    mass: float
    wheel_radius: float
    max_drive_torque: float
    max_brake_torque: float
    drag_coefficient_area: float = DEFAULT_PHYSICS["drag_coefficient_area"]
    rolling_resistance: float = DEFAULT_PHYSICS["rolling_resistance"]

    @classmethod
    def from_physics(cls, physics: Mapping[str, Any] | None, *, source: str | None = None
                     ) -> LongitudinalMap:
        """Read the map from a vehicle's ``physics`` section (``None``: the defaults).

        ``source`` names the vehicle file in error messages.
        """
        if physics is None:
            return cls(**DEFAULT_PHYSICS)
        values: dict[str, float] = {}
        for key in REQUIRED_PHYSICS_KEYS + OPTIONAL_PHYSICS_KEYS:
            if key not in physics:
                if key in REQUIRED_PHYSICS_KEYS:
                    raise InputError("missing, the longitudinal controller needs it",
                                     file=source, field=f"physics.{key}")
                values[key] = DEFAULT_PHYSICS[key]
                continue
            raw = physics[key]
            try:
                value = float(raw)
            except (TypeError, ValueError):
                raise InputError(f"must be a number, got {raw!r}", file=source,
                                 field=f"physics.{key}") from None
            positive = key in REQUIRED_PHYSICS_KEYS
            if not math.isfinite(value) or value < 0 or (positive and value == 0):
                raise InputError(f"must be {'> 0' if positive else '>= 0'}, got {raw!r}",
                                 file=source, field=f"physics.{key}")
            values[key] = value
        return cls(**values)

    @classmethod
    def for_vehicle(cls, vehicle) -> LongitudinalMap:
        physics = vehicle.physics
        if hasattr(physics, "model_dump"):
            physics = physics.model_dump()
        return cls.from_physics(physics, source=vehicle_source(vehicle))

    # --- forces -------------------------------------------------------------------------
    def resistance_force(self, v: float) -> float:
        """Rolling plus aerodynamic resistance [N] at speed ``v`` (magnitude, >= 0)."""
        v = abs(v)
        return (self.rolling_resistance * self.mass * GRAVITY
                + 0.5 * AIR_DENSITY * self.drag_coefficient_area * v * v)

    @property
    def max_brake_deceleration(self) -> float:
        return self.max_brake_torque / (self.wheel_radius * self.mass)

    # --- the two directions -------------------------------------------------------------
    def pedals(self, acceleration: float, v: float) -> tuple[float, float]:
        """(throttle, brake) in [0, 1] that produce ``acceleration`` at speed ``v`` (>= 0).

        Resistance is compensated: a small deceleration is obtained by coasting with a
        little throttle rather than by braking; throttle and brake are never both > 0.
        """
        wheel_force = self.mass * acceleration + self.resistance_force(v)
        if wheel_force >= 0.0:
            throttle = wheel_force * self.wheel_radius / self.max_drive_torque
            return min(throttle, 1.0), 0.0
        brake = -wheel_force * self.wheel_radius / self.max_brake_torque
        return 0.0, min(brake, 1.0)

    def acceleration(self, throttle: float, brake: float, v: float) -> float:
        """Longitudinal acceleration [m/s^2] from pedal positions at speed ``v`` (forward > 0).

        At standstill (``|v|`` below 1 mm/s) brake and resistance act as static friction:
        they hold the vehicle but never push it backwards.
        """
        throttle = min(max(throttle, 0.0), 1.0)
        brake = min(max(brake, 0.0), 1.0)
        drive = throttle * self.max_drive_torque / self.wheel_radius
        opposing = brake * self.max_brake_torque / self.wheel_radius + self.resistance_force(v)
        if abs(v) < 1e-3:
            return max(drive - opposing, 0.0) / self.mass
        return (drive - math.copysign(opposing, v)) / self.mass


def vehicle_source(vehicle) -> str:
    """How error messages name a vehicle: its catalogue data file when it has one."""
    try:
        from importlib import resources

        path = resources.files("simgap.vehicles") / "data" / f"{vehicle.name}.yaml"
        if path.is_file():
            return str(path)
    except (ModuleNotFoundError, TypeError):  # pragma: no cover - packaging oddities
        pass
    return f"vehicle '{vehicle.name}'"


class SpeedGains(BaseModel):
    """Gains of the speed controller shared by every tracking controller (key ``speed``)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    kp: float = Field(1.5, ge=0, description="speed error -> acceleration [1/s]")
    ki: float = Field(0.2, ge=0, description="integral of speed error -> acceleration [1/s^2]")
    kd: float = Field(0.0, ge=0, description="acceleration error (plan a - measured a) [-]")
    integral_limit: float = Field(
        1.0, ge=0, description="bound on the integral term's contribution [m/s^2]")
    integral_band: float = Field(
        1.0, ge=0, description="the integral runs only while |speed error| is below this, so "
        "that large steps do not wind it up [m/s]")
    accel_feedforward: float = Field(
        1.0, ge=0, le=1.5, description="weight of the plan's acceleration [-]")
    position_gain: float = Field(
        0.5, ge=0, description="along-track position error -> speed correction [1/s]")
    position_correction_limit: float = Field(
        2.0, ge=0, description="bound on the speed correction from the position error [m/s]")
    max_decel: float | None = Field(
        None, gt=0, description="deceleration limit [m/s^2]; default: the vehicle's max_accel")
    standstill_speed: float = Field(
        0.1, ge=0, description="below this plan and measured speed the vehicle is held [m/s]")
    standstill_brake: float = Field(0.4, ge=0, le=1, description="brake pedal holding a stop [-]")


class SpeedController:
    """Acceleration demand from the plan's speed and acceleration, mapped to pedals."""

    def __init__(self, gains: SpeedGains, pedal_map: LongitudinalMap, max_accel: float):
        self.gains = gains
        self.map = pedal_map
        self.max_accel = float(max_accel)
        self.max_decel = float(gains.max_decel if gains.max_decel is not None else max_accel)
        self._integral = 0.0
        self.last_demand = 0.0

    def reset(self) -> None:
        self._integral = 0.0
        self.last_demand = 0.0

    def demand(self, v: float, a: float, v_ref: float, a_ref: float, along_track_error: float,
               dt: float) -> float:
        """Acceleration demand [m/s^2]. ``along_track_error`` > 0: the vehicle is behind the plan."""
        g = self.gains
        v_ref = max(v_ref, 0.0)
        correction = g.position_gain * along_track_error
        lim = g.position_correction_limit
        v_target = max(v_ref + min(max(correction, -lim), lim), 0.0)
        error = v_target - v
        unsaturated = (g.accel_feedforward * a_ref + g.kp * error + self._integral
                       + g.kd * (a_ref - a))
        # Conditional integration (anti-windup): stop integrating into a saturated demand.
        saturated_up = unsaturated >= self.max_accel and error > 0
        saturated_down = unsaturated <= -self.max_decel and error < 0
        if g.ki > 0 and abs(error) < g.integral_band and not (saturated_up or saturated_down):
            ilim = g.integral_limit
            self._integral = min(max(self._integral + g.ki * error * dt, -ilim), ilim)
        demand = (g.accel_feedforward * a_ref + g.kp * error + self._integral
                  + g.kd * (a_ref - a))
        demand = min(max(demand, -self.max_decel), self.max_accel)
        self.last_demand = demand
        return demand

    def pedals(self, v: float, a: float, v_ref: float, a_ref: float, along_track_error: float,
               dt: float, *, stop_planned: bool) -> tuple[float, float]:
        """(throttle, brake). ``stop_planned``: the plan stands still now and just ahead."""
        g = self.gains
        if stop_planned and v < g.standstill_speed:
            self._integral = 0.0
            self.last_demand = 0.0
            return 0.0, g.standstill_brake
        demand = self.demand(v, a, v_ref, a_ref, along_track_error, dt)
        return self.map.pedals(demand, max(v, 0.0))
