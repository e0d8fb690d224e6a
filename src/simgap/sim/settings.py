"""Settings every physics backend shares, each bound and default written once: the tracking
(controller, its rate and gains, actuator delays) and the road's friction. A backend's own
settings model extends `TrackingSettings`; a world with a road surface extends `RoadSurface`."""

from __future__ import annotations

from typing import Annotated, Any

from pydantic import BaseModel, ConfigDict, Field, field_validator

from simgap.control import DEFAULT_CONTROLLER, controller_names
from simgap.control.tracking import CONTROLLER_HZ, MIN_RATE_HZ

MAX_ACTUATOR_DELAY_S = 1.0      # s: longer dead times are no actuator but a broken car
DRY_ROAD_FRICTION = 1.0         # the tyres' own friction, unscaled (the ideal world's assumption)

ActuatorDelay = Annotated[float, Field(ge=0.0, le=MAX_ACTUATOR_DELAY_S)]
RoadFriction = Annotated[float, Field(ge=0.1, le=1.5, description="scales each tyre's friction [-]")]


class RoadSurface(BaseModel):
    """The settings of a world with a road surface: its friction."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    road_friction: RoadFriction = DRY_ROAD_FRICTION


def road_friction(settings: BaseModel | None) -> float:
    """The friction of a world's road: its setting, or the dry road of a world without one (the
    ideal world's assumption)."""
    return settings.road_friction if isinstance(settings, RoadSurface) else DRY_ROAD_FRICTION


class TrackingSettings(BaseModel):
    """How each car of a physics backend follows its plan."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    controller: str = Field(DEFAULT_CONTROLLER, description="tracking controller: pure_pursuit, stanley, lqr")
    controller_hz: float = Field(CONTROLLER_HZ, ge=MIN_RATE_HZ, description="controller rate [Hz]")
    controller_gains: dict[str, Any] = Field(default_factory=dict,
                                             description="gains over the controller's defaults and the vehicle's")
    steer_delay: ActuatorDelay = Field(0.0, description="steering actuator dead time [s]")
    pedal_delay: ActuatorDelay = Field(0.0, description="throttle and brake dead time [s]")

    @field_validator("controller")
    @classmethod
    def _known_controller(cls, name: str) -> str:
        if name not in controller_names():
            raise ValueError(f"unknown controller '{name}'; known: {', '.join(controller_names())}")
        return name
