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
* Suspension stiffness and damping are per wheel at the wheel centre (wheel rates); an axle's
  anti-roll bar resists the body's roll against the axle (N m/rad), not its heave.
* ``max_drive_torque`` is the torque at the driven wheels, summed, in first gear at full
  throttle; ``max_power`` caps it at speed (``torque <= power / wheel speed``).
* ``tyres`` are the four (alike) tyres (`simgap.vehicles.tyres`); ``wheel_radius`` is their
  loaded rolling radius at static load.
* ``max_brake_torque`` is the summed torque of all four brakes at full pedal;
  ``brake_front_share`` of it acts on the front axle.
"""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict, Field

from simgap.vehicles.constants import GRAVITY, MAX_MASS, MAX_POWER
from simgap.vehicles.tyres import Tyres


class Suspension(BaseModel):
    """One axle's suspension, per wheel."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    stiffness: float = Field(gt=0, description="wheel rate [N/m]")
    damping: float = Field(gt=0, description="damping at the wheel [N s/m]")
    travel: float = Field(gt=0, description="travel each way from static ride height [m]")
    anti_roll: float = Field(0.0, ge=0,
                             description="anti-roll bar of the axle: moment per body roll against the axle [N m/rad]")
    camber_gain: float = Field(0.0, ge=-2.0, le=2.0,
                               description="camber change per bump travel [rad/m]; < 0: the top leans in as the wheel rises")

    def roll_stiffness(self, track: float) -> float:
        """The axle's roll stiffness [N m/rad]: its two springs (``k t^2 / 2``) and its anti-roll bar."""
        return self.stiffness * track ** 2 / 2.0 + self.anti_roll


class Steering(BaseModel):
    """The steering system as the steering actuator realises it."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    ratio: float = Field(gt=0, description="steering-wheel angle / road-wheel angle [-]")
    max_angle: float = Field(gt=0, lt=1.2, description="max road-wheel angle (inner wheel, Ackermann) [rad]")
    max_rate: float = Field(gt=0, description="max road-wheel angle rate [rad/s]")


class VehiclePhysics(BaseModel):
    """A four-wheeled car: sprung chassis, suspension, tyres, steering, powertrain, brakes."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    mass: float = Field(gt=0, le=MAX_MASS, description="total mass [kg]")
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
    tyres: Tyres = Field(description="the tyres: Magic Formula coefficients, radial stiffness, relaxation lengths")
    steering: Steering
    max_drive_torque: float = Field(gt=0, description="summed drive torque at the wheels [N m]")
    max_power: float = Field(gt=0, le=MAX_POWER, description="max power at the wheels [W]")
    driven_axles: Literal["front", "rear", "all"] = Field(description="which wheels are driven")
    drive_front_share: float = Field(0.5, ge=0, le=1, description="front share of drive torque when all wheels are driven [-]")
    max_brake_torque: float = Field(gt=0, description="summed brake torque of all wheels [N m]")
    brake_front_share: float = Field(gt=0, lt=1, description="front axle share of brake torque [-]")
    drag_coefficient_area: float = Field(0.64, ge=0, description="drag coefficient times frontal area [m^2]")
    rolling_resistance: float = Field(0.012, ge=0, description="rolling-resistance coefficient [-]")

    @property
    def tyre_friction(self) -> float:
        """Peak tyre-road friction on the reference (dry) road."""
        return self.tyres.peak_friction

    def axle_cornering_stiffness(self, wheelbase: float, rear_axle_to_center: float,
                                 gravity: float = GRAVITY) -> tuple[float, float]:
        """Cornering stiffness of the front and of the rear axle (both tyres) at static load [N/rad]."""
        b = rear_axle_to_center
        a = wheelbase - b
        front_load = self.mass * gravity * b / wheelbase / 2.0
        rear_load = self.mass * gravity * a / wheelbase / 2.0
        return (2.0 * abs(self.tyres.cornering_stiffness(front_load)),
                2.0 * abs(self.tyres.cornering_stiffness(rear_load)))

    def understeer_gradient(self, wheelbase: float, rear_axle_to_center: float) -> float:
        """Linear-range understeer gradient of the tyres at static axle loads [rad s^2/m]:
        K_us = m / L (b / C_f - a / C_r), C the axle's cornering stiffness (steering angle
        delta = L / R + K_us a_y on a steady circle). Load transfer, roll and compliance are not
        in it; `bench/vehicles/vehicle_dynamics.py` measures the whole car."""
        c_front, c_rear = self.axle_cornering_stiffness(wheelbase, rear_axle_to_center)
        b = rear_axle_to_center
        return self.mass / wheelbase * (b / c_front - (wheelbase - b) / c_rear)

    def steady_sideslip(self, wheelbase: float, rear_axle_to_center: float, speed: float, yaw_rate: float) -> float:
        """Sideslip at the centre of gravity [rad] in steady cornering at ``speed`` and
        ``yaw_rate`` with linear tyres: beta = b / R - m a v^2 / (L C_r R)."""
        _, c_rear = self.axle_cornering_stiffness(wheelbase, rear_axle_to_center)
        a = wheelbase - rear_axle_to_center
        return rear_axle_to_center * yaw_rate / speed - self.mass * a * speed * yaw_rate / (wheelbase * c_rear)

    def steady_roll(self, lateral_acceleration: float, gravity: float = GRAVITY) -> float:
        """Body roll [rad, about the forward axis, > 0 left side up] in steady cornering at
        ``lateral_acceleration`` (> 0 turning left): the sprung mass's moment about the ground,
        held by the axles' roll stiffness (springs and anti-roll bars)."""
        stiffness = (self.suspension_front.roll_stiffness(self.track_front)
                     + self.suspension_rear.roll_stiffness(self.track_rear))
        moment_arm = self.sprung_mass * self.cg_height
        return moment_arm * lateral_acceleration / (stiffness - moment_arm * gravity)

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
