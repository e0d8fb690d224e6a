"""Vehicle data files and the model they are read into.

Every vehicle is one YAML file in ``simgap/vehicles/data``; adding a vehicle is adding a file.
The ``planner`` section holds what a planner assumes (CommonRoad's kinematic limits); the
``physics`` section, when present, what a physics backend builds (see the MuJoCo backend).
"""

from __future__ import annotations

from functools import cache
from importlib import resources
from pathlib import Path
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationInfo, field_validator

from simgap.errors import InputError
from simgap.files import read_model
from simgap.vehicles.actuators import Actuators
from simgap.vehicles.constants import MAX_LENGTH, MAX_SPEED, MAX_WIDTH
from simgap.vehicles.physics import VehiclePhysics
from simgap.vehicles.reference_points import along_heading

DEFAULT_VEHICLE = "sedan"     # every agent's vehicle, and the one its planner assumes, unless told otherwise


class VehicleLimits(BaseModel):
    """Kinematic limits as CommonRoad's vehicle models state them (SI units)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    max_steer: float = Field(gt=0, description="max road-wheel steering angle [rad]")
    max_steer_rate: float = Field(gt=0, description="max steering rate [rad/s]")
    max_accel: float = Field(gt=0, description="max longitudinal acceleration magnitude [m/s^2]")
    max_speed: float = Field(gt=0, le=MAX_SPEED, description="max speed [m/s]")
    v_switch: float = Field(gt=0, description="speed above which acceleration is power-limited [m/s]")


class Vehicle(BaseModel):
    """One vehicle of the catalogue."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    name: str
    description: str = ""
    source: str = Field("", description="where the numbers come from")
    length: float = Field(gt=0, le=MAX_LENGTH, description="body length [m]")
    width: float = Field(gt=0, le=MAX_WIDTH, description="body width [m]")
    wheelbase: float = Field(gt=0, description="front to rear axle [m], at most the length")
    rear_axle_to_center: float = Field(gt=0, description="rear axle to the vehicle centre [m], less than the wheelbase")
    limits: VehicleLimits
    commonroad_vehicle_type: Literal[1, 2, 3] | None = Field(
        None, description="the CommonRoad vehicle type (parameter set) this vehicle is, when it is one: 1 Ford "
                          "Escort, 2 BMW 320i, 3 VW Vanagon; a planner driving it is scored as that type")
    physics: VehiclePhysics | None = Field(None, description="physical model for 3D backends")
    actuators: Actuators | None = Field(
        None, description="each actuator channel's dead time and lag (None: they act at once)")
    controllers: dict[str, dict[str, Any]] = Field(
        default_factory=dict, description="controller gains by controller name, overriding defaults")

    @field_validator("wheelbase")
    @classmethod
    def _axles_on_the_body(cls, wheelbase: float, info: ValidationInfo) -> float:
        length = info.data.get("length")
        if length is not None and wheelbase > length:
            raise ValueError(f"{wheelbase:g} m, longer than the vehicle (allowed: <= length, {length:g} m)")
        return wheelbase

    @field_validator("rear_axle_to_center")
    @classmethod
    def _centre_between_the_axles(cls, rear_axle_to_center: float, info: ValidationInfo) -> float:
        wheelbase = info.data.get("wheelbase")
        if wheelbase is not None and rear_axle_to_center >= wheelbase:
            raise ValueError(f"{rear_axle_to_center:g} m puts the centre outside the wheelbase "
                             f"(allowed: < wheelbase, {wheelbase:g} m)")
        return rear_axle_to_center

    @property
    def data(self) -> dict[str, Any]:
        """Every field as a JSON object (what a planner in its own process gets as ``vehicle.data``)."""
        return self.model_dump(mode="json")

    @property
    def front_axle_to_center(self) -> float:
        return self.wheelbase - self.rear_axle_to_center

    def centre_of(self, x_rear, y_rear, yaw):
        """The centre of this vehicle with its rear axle at ``(x_rear, y_rear)`` (floats or arrays)."""
        return along_heading(x_rear, y_rear, yaw, self.rear_axle_to_center)

    def rear_axle_of(self, x, y, yaw):
        """The rear axle of this vehicle centred at ``(x, y)`` (floats or arrays)."""
        return along_heading(x, y, yaw, -self.rear_axle_to_center)


def _data_dir() -> Path:
    return Path(str(resources.files("simgap.vehicles") / "data"))


def vehicle_names() -> list[str]:
    return sorted(p.stem for p in _data_dir().glob("*.yaml"))


def load_vehicle_file(path: str | Path) -> Vehicle:
    path = Path(path)
    return read_model(path, Vehicle, "vehicle file", defaults={"name": path.stem})


def is_vehicle_file(name_or_path: str) -> bool:
    """Whether a vehicle reference names a data file (else a catalogue name)."""
    return name_or_path.endswith((".yaml", ".yml")) or "/" in name_or_path


@cache
def load_vehicle(name_or_path: str) -> Vehicle:
    """A vehicle by catalogue name (``sedan``) or by the path of a data file."""
    if is_vehicle_file(name_or_path):
        return load_vehicle_file(name_or_path)
    path = _data_dir() / f"{name_or_path}.yaml"
    if not path.exists():
        raise InputError(f"unknown vehicle '{name_or_path}'", field="vehicle",
                         allowed=", ".join(vehicle_names()))
    return load_vehicle_file(path)
