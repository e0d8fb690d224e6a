"""The physical model of a vehicle: what a physics backend builds and what the longitudinal
controller maps pedals with. Every quantity in SI units (m, kg, s, rad, N, N m, W).

Conventions:

* The centre of gravity sits, in plan view, at the vehicle's centre (the reference point of
  every `State`), so ``rear_axle_to_center`` of the vehicle also sets the axle load split;
  ``cg_height`` is measured from the ground at static ride height.
* ``mass`` is the whole vehicle; ``wheel_mass`` is the unsprung mass at one corner (wheel,
  tyre, hub, brake, half the link mass); the sprung chassis carries the rest.
* Inertias are about the centre of gravity: roll about x (forward), pitch about y (left),
  yaw about z (up).
* Suspension stiffness and damping are per wheel at the wheel centre (wheel rates).
* ``max_drive_torque`` is the torque at the driven wheels, summed, in first gear at full
  throttle; ``max_power`` caps it at speed (``torque <= power / wheel speed``).
* ``max_brake_torque`` is the summed torque of all four brakes at full pedal;
  ``brake_front_share`` of it acts on the front axle.
"""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict, Field


class Suspension(BaseModel):
    """One axle's suspension, per wheel."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    stiffness: float = Field(gt=0, description="wheel rate [N/m]")
    damping: float = Field(gt=0, description="damping at the wheel [N s/m]")
    travel: float = Field(gt=0, description="travel each way from static ride height [m]")


class Steering(BaseModel):
    """The steering system as the steering actuator realises it."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    ratio: float = Field(gt=0, description="steering-wheel angle / road-wheel angle [-]")
    max_angle: float = Field(gt=0, lt=1.2, description="max road-wheel angle (inner wheel, Ackermann) [rad]")
    max_rate: float = Field(gt=0, description="max road-wheel angle rate [rad/s]")


class VehiclePhysics(BaseModel):
    """A four-wheeled car: sprung chassis, suspension, tyres, steering, powertrain, brakes."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    mass: float = Field(gt=0, description="total mass [kg]")
    inertia_roll: float = Field(gt=0, description="sprung-mass inertia about x [kg m^2]")
    inertia_pitch: float = Field(gt=0, description="sprung-mass inertia about y [kg m^2]")
    inertia_yaw: float = Field(gt=0, description="whole-vehicle inertia about z [kg m^2]")
    height: float = Field(gt=0, description="overall body height [m]")
    cg_height: float = Field(gt=0, description="centre of gravity above ground [m]")
    track_front: float = Field(gt=0, description="front track width [m]")
    track_rear: float = Field(gt=0, description="rear track width [m]")
    wheel_radius: float = Field(gt=0, description="rolling radius [m]")
    wheel_width: float = Field(gt=0, description="tyre width [m]")
    wheel_mass: float = Field(gt=0, description="unsprung mass per corner [kg]")
    wheel_inertia: float = Field(gt=0, description="wheel spin inertia [kg m^2]")
    suspension_front: Suspension
    suspension_rear: Suspension
    tyre_friction: float = Field(gt=0, le=2.0, description="peak tyre-road friction on dry asphalt [-]")
    steering: Steering
    max_drive_torque: float = Field(gt=0, description="summed drive torque at the wheels [N m]")
    max_power: float = Field(gt=0, description="max power at the wheels [W]")
    driven_axles: Literal["front", "rear", "all"] = Field(description="which wheels are driven")
    drive_front_share: float = Field(0.5, ge=0, le=1, description="front share of drive torque when all wheels are driven [-]")
    max_brake_torque: float = Field(gt=0, description="summed brake torque of all wheels [N m]")
    brake_front_share: float = Field(gt=0, lt=1, description="front axle share of brake torque [-]")
    drag_coefficient_area: float = Field(0.64, ge=0, description="drag coefficient times frontal area [m^2]")
    rolling_resistance: float = Field(0.012, ge=0, description="rolling-resistance coefficient [-]")

    @property
    def sprung_mass(self) -> float:
        return self.mass - 4.0 * self.wheel_mass

    def drive_shares(self) -> tuple[float, float]:
        """Share of drive torque on the (front, rear) axle."""
        if self.driven_axles == "front":
            return 1.0, 0.0
        if self.driven_axles == "rear":
            return 0.0, 1.0
        return self.drive_front_share, 1.0 - self.drive_front_share
